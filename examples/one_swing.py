"""Run one swing and print its summary (copy and adapt)."""
from bplir_drake.analysis.swing.swing_runner import run_swing
from bplir_drake.plotting import save_figure
from bplir_drake.params import preset

params = preset("dissertation")
result = run_swing(params, seed=3)          # friction drawn +/-20 %, IMU noise, EKF in the loop
for key in ("outcome", "swing_time_s", "capture_speed_mps", "peak_torque_Nm", "seed"):
    print(f"{key:20s} {result.summary[key]}")
save_figure(result.plot(), "one_swing.png")   # result.plot(axes) draws on your own axes
