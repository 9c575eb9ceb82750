"""Plot a log written by `bplir swing --out DIR` (DIR/swing_log.csv)."""
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

log = np.genfromtxt(sys.argv[1] if len(sys.argv) > 1 else "out/swing/swing_log.csv",
                    delimiter=",", names=True)
fig, ax = plt.subplots(2, 1, sharex=True, figsize=(8, 6))
ax[0].plot(log["t"], log["q1"], label="q1")
ax[0].plot(log["t"], log["q2"], label="q2")
ax[0].plot(log["t"], log["q2_ref"], "k--", label="q2 reference")
ax[0].legend()
ax[1].plot(log["gripper_x"], log["gripper_y"])
ax[1].axhline(0, color="k")
ax[1].set_xlabel("gripper x [m]")
fig.savefig("saved_log.png", dpi=100)
print("wrote saved_log.png")
