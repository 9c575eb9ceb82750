"""Estimation studies: the EKF on a simulated swing against the truth and
gyro integration, and observability along a trajectory."""
