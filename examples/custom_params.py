"""Parameters from TOML: a heavier simulated robot with more elbow friction,
a wider grip spacing, and a different seed; the controller keeps the nominal model."""
import tempfile
from pathlib import Path

from bplir_drake.analysis.swing.swing_runner import run_swing
from bplir_drake.params import load_toml

text = """
preset = "dissertation"
[true_plant]          # the simulated robot (the controller keeps [plant])
m2 = 1.6
[true_friction]
fc2 = 0.85
[scenario]
grip_spacing = 1.15
seed = 11
"""
path = Path(tempfile.mkdtemp()) / "robot.toml"
path.write_text(text)
params = load_toml(path)          # a bad value raises ParameterError naming field and range
print(run_swing(params).summary["outcome"])
