import subprocess
import sys

CODE = """
import sys, pkgutil, importlib, volcal
skip = ('volcal.plot', 'volcal.report', 'volcal.cli')
loaded = []
for m in pkgutil.walk_packages(volcal.__path__, 'volcal.', onerror=lambda name: None):
    if m.name.startswith(skip):
        continue
    try:
        importlib.import_module(m.name)
    except Exception:  # a module still being written elsewhere; not this test's business
        continue
    loaded.append(m.name)
bad = [k for k in sys.modules if k.startswith('matplotlib')]
assert not bad, bad[:3]
assert 'volcal.model.kinematics' in loaded and 'volcal.session.format' in loaded, loaded
print(len(loaded))
"""


def test_analysis_code_does_not_import_matplotlib():
    r = subprocess.run([sys.executable, "-c", CODE], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert int(r.stdout.strip()) >= 10
