"""The steps of the flow, one library function each, behind both faces.

Each step of the calibration flow is one function with keyword arguments named once
and a typed (frozen) result holding everything the command line prints and writes:

==========  ==================================  ===========
step        function (module.function)          result
==========  ==================================  ===========
plan        ``plan.plan``                       Planned
plan --add  ``plan.add``                        Added
advise      ``advise.advise``                   Advice
program     ``program.program``                 Programs
simulate    ``simulate.simulate`` (``.save``)   Simulated
import      ``importer.import_``                Imported
identify    ``identify.identify``               Identified
predict     ``predict.predict``                 Prediction
compensate  ``compensate.compensate``           Compensated
evaluate    ``evaluate.evaluate`` (verdict)     Evaluated
report      ``report.report`` (certificate)     Reported
==========  ==================================  ===========

The command line (``volcal.cli``) parses text, calls the step and prints its result;
:class:`volcal.Calibration` keeps the state and calls the same function. A wrong value
is a :class:`~volcal.errors.ParameterError` naming the Python parameter; the command
line prints it with its option names (``volcal.cli._options.OPTIONS``). The defaults
are the step's signature's, from :mod:`volcal.defaults`. No module here is imported by
``import volcal``.
"""
