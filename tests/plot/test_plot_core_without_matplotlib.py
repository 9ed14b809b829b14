import subprocess
import sys

# Module names are listed from the file system: pkgutil.walk_packages would import
# volcal.plot itself while walking.
CODE = """
import sys, importlib, pathlib, volcal
root = pathlib.Path(volcal.__file__).parent
# the demo (on top of the facade) and the history's report section write reports
skip = ('volcal.plot', 'volcal.report', 'volcal.cli', 'volcal.demo', 'volcal.history.previous')
loaded = []
for f in sorted(root.rglob('*.py')):
    parts = f.relative_to(root.parent).with_suffix('').parts
    name = '.'.join(parts[:-1] if parts[-1] == '__init__' else parts)
    if name.startswith(skip):
        continue
    try:
        importlib.import_module(name)
    except Exception:  # a module still being written elsewhere; not this test's business
        continue
    loaded.append(name)
bad = [k for k in sys.modules if k.startswith('matplotlib')]
assert not bad, bad[:3]
assert 'volcal.model.kinematics' in loaded and 'volcal.session.format' in loaded, loaded
print(len(loaded))
"""


def test_analysis_code_does_not_import_matplotlib():
    r = subprocess.run([sys.executable, "-c", CODE], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert int(r.stdout.strip()) >= 10
