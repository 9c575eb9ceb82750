"""Three Monte Carlo samples through one built diagram, plotted on your own axes.

A sample's simulated robot (link inertias, friction), IMU errors, wind and
gusts and its seeds live in the Drake context, so SwingRunner builds the
diagram once and writes each sample into a fresh context.
"""
from matplotlib.figure import Figure

from bplir_drake.analysis.montecarlo import Distribution, Study, sample_params
from bplir_drake.plotting import save_figure
from bplir_drake.analysis.swing import SwingRunner
from bplir_drake.params import preset

study = Study(preset("dissertation"),
              (Distribution("true_friction.fv1", "uniform", rel=0.2),
               Distribution("true_plant.m2", "uniform", rel=0.1),
               Distribution("imu.gyro_bias1", "uniform", abs=0.01)),
              samples=3, seed=7)
runner = SwingRunner()
fig = Figure(figsize=(12, 9))
axes = fig.subplots(3, 2, sharex=True)
for index in range(study.samples):
    params, seed, drawn = sample_params(study, index)
    result = runner.run(params, seed=seed)
    print(index, {k: round(v, 4) for k, v in drawn.items()}, result.summary["outcome"],
          f"{result.summary['capture_speed_mps']:.3f} m/s")
    result.plot(axes)            # all three samples on the same six axes
print(f"diagrams built: {runner.builds}")
fig.tight_layout()
save_figure(fig, "samples.png")
