"""Measurement uncertainty (GUM): the budget of a laser measurement and of its results.

Low in the layering, beside :mod:`volcal.environment`: the standards and the CLI use it,
it uses neither. The propagation runs on the GUM Tree Calculator (``GTC``, Measurement
Standards Laboratory of New Zealand), imported inside the functions that need it, so
``import volcal.uncertainty`` stays light.

Modules
-------
budget
    The budget file (TOML): reader, validator and the documented template.
sensitivity
    Sensitivities from volcal's own models: d n / d t, d n / d p, d n / d RH of the air
    (Ciddor or Edlén by numerical derivative).
propagation
    GUM propagation on GTC: inputs with distribution and degrees of freedom, product terms
    with their second-order part, one-sided (bias) terms, Welch-Satterthwaite and ``k``.
laser
    The contributors of a laser length reading at a given length (wavelength, air,
    material, cosine error, dead path).

The ISO 230-2 parameters' uncertainty is computed above this package, in
:mod:`volcal.standards.iso230_2_uncertainty` (the standards use this package; it uses
neither the standards nor the identification).

See ``docs/uncertainty.md``.
"""
