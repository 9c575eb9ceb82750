"""The same-run yardstick of ``bench_swing.py``: a loop of the kind the DFKI
double_pendulum simulator runs (an acrobot stepped by fixed-step RK4 at
2 ms in plain NumPy, a PFL + LQR controller called every step, no
estimator), on the BPLIR's nominal links.  Written here, not imported:
the peer is not installable from the package registries.
"""
import time

import numpy as np


class _PeerPlant:
    """An acrobot written the way the peer writes its plant: a method per
    matrix of the equations of motion (each copying the state it reads,
    numpy's scalar functions), viscous and Coulomb friction per joint in a
    loop, the mass matrix inverted every call, both joints' torques as a
    vector through the actuation matrix (the elbow's alone acts)."""

    def __init__(self, p):
        pl, fr = p.plant, p.friction
        self.m, self.l, self.com = [pl.m1, pl.m2], [pl.l1, pl.l2], [pl.rc1, pl.rc2]
        self.I, self.g = [pl.I1 + pl.m1 * pl.rc1 ** 2, pl.I2 + pl.m2 * pl.rc2 ** 2], pl.g
        self.b, self.cf = [fr.fv1, fr.fv2], [fr.fc1, fr.fc2]
        self.B = np.array([[0.0, 0.0], [0.0, 1.0]])

    def mass_matrix(self, x):
        pos = np.copy(x[:2])
        h = self.m[1] * self.l[0] * self.com[1] * np.cos(pos[1])
        m00 = self.I[0] + self.I[1] + self.m[1] * self.l[0] ** 2.0 + 2 * h
        m01 = self.I[1] + h
        return np.array([[m00, m01], [m01, self.I[1]]])

    def coriolis_matrix(self, x):
        pos, vel = np.copy(x[:2]), np.copy(x[2:])
        h = self.m[1] * self.l[0] * self.com[1] * np.sin(pos[1])
        return np.array([[-2 * h * vel[1], -h * vel[1]], [h * vel[0], 0.0]])

    def gravity_vector(self, x):
        pos = np.copy(x[:2])
        s1, s12 = np.sin(pos[0]), np.sin(pos[0] + pos[1])
        return np.array([-(self.m[0] * self.com[0] + self.m[1] * self.l[0]) * self.g * s1
                         - self.m[1] * self.g * self.com[1] * s12,
                         -self.m[1] * self.g * self.com[1] * s12])

    def coulomb_vector(self, x):
        vel = np.copy(x[2:])
        F = np.zeros(2)
        for i in range(2):
            F[i] = self.b[i] * vel[i] + self.cf[i] * np.arctan(100 * vel[i])
        return F

    def rhs(self, t, x, tau):
        vel = np.copy(x[2:])
        M, C = self.mass_matrix(x), self.coriolis_matrix(x)
        G, F = self.gravity_vector(x), self.coulomb_vector(x)
        acc = np.linalg.inv(M).dot(G + self.B.dot(tau) - C.dot(vel) - F)
        res = np.zeros(4)
        res[0], res[1], res[2], res[3] = x[2], x[3], acc[0], acc[1]
        return res

    def energy(self, x):
        M = self.mass_matrix(x)
        vel = np.copy(x[2:])
        pos = np.copy(x[:2])
        y1 = -self.com[0] * np.cos(pos[0])
        y2 = -self.l[0] * np.cos(pos[0]) - self.com[1] * np.cos(pos[0] + pos[1])
        return 0.5 * vel.dot(M.dot(vel)) + self.g * (self.m[0] * y1 + self.m[1] * y2)


def reference_loop_rate(duration: float = 10.0, dt: float = 0.002) -> float:
    """Simulated s per wall s of the kind of loop the DFKI double_pendulum
    simulator runs, written here in plain NumPy (:class:`_PeerPlant`):
    fixed-step RK4 at ``dt`` on the BPLIR's nominal acrobot; every step an
    energy-shaping collocated partial feedback linearisation (PFL) and an
    LQR about the upright state (its gain from Drake) are both evaluated
    and one is chosen by the distance to the upright state; the torque
    vector clipped to the limits; time, state and torque recorded in lists;
    each controller call recorded, filtered and compensated as the peer's
    controllers do (:func:`control`).  No estimator, sensors, motor or
    events: the same-run yardstick of the closed loop's rate."""
    from pydrake.systems.controllers import LinearQuadraticRegulator

    from bplir_drake.params import preset

    p = preset()
    plant = _PeerPlant(p)
    limit = np.array([0.0, p.motor.torque_limit])
    up, eps = np.array([np.pi, 0.0, 0.0, 0.0]), 1e-6
    A = np.column_stack([(plant.rhs(0, up + eps * e, np.zeros(2))
                          - plant.rhs(0, up - eps * e, np.zeros(2))) / (2 * eps)
                         for e in np.eye(4)])
    Bl = ((plant.rhs(0, up, np.array([0.0, eps])) - plant.rhs(0, up, np.array([0.0, -eps])))
          / (2 * eps)).reshape(4, 1)
    K, _ = LinearQuadraticRegulator(A, Bl, np.diag([10.0, 10.0, 1.0, 1.0]), np.eye(1))
    E_up = plant.energy(up)

    hist = {name: [] for name in ("x", "x_filtered", "u", "u_friction", "u_gravity")}

    def pfl(t, x):   # energy shaping through a collocated PFL (the swing-up)
        M, C = plant.mass_matrix(x), plant.coriolis_matrix(x)
        G, F = plant.gravity_vector(x), plant.coulomb_vector(x)
        h = C.dot(np.copy(x[2:])) - G + F
        a2 = 2.0 * (E_up - plant.energy(x)) * x[2] - 50.0 * x[1] - 5.0 * x[3]
        a1 = -(M[0, 1] * a2 + h[0]) / M[0, 0]
        return np.array([0.0, M[1, 0] * a1 + M[1, 1] * a2 + h[1]])

    def lqr(t, x):   # the balance about the upright state
        e = np.copy(x) - up
        e[0] = (e[0] + np.pi) % (2 * np.pi) - np.pi
        return np.array([0.0, -K.dot(e)[0]])

    def control(t, x):
        """A controller call as the peer's controllers make it: the state
        recorded and filtered (identity), both laws' switching condition
        checked, the chosen law, friction compensation through the friction
        regressor (off: zero terms) and gravity compensation (off)."""
        hist["x"].append(x)
        y = np.copy(x)
        hist["x_filtered"].append(y)
        e = np.copy(y) - up
        e[0] = (e[0] + np.pi) % (2 * np.pi) - np.pi
        near = float(e.dot(np.diag([1.0, 1.0, 0.1, 0.1]).dot(e))) < 0.1
        u = np.asarray(lqr(t, y) if near else pfl(t, y))
        regressor = np.array([[np.arctan(100 * y[2]), y[2], 0.0, 0.0],
                              [0.0, 0.0, np.arctan(100 * y[3]), y[3]]])
        u_fric = np.dot(regressor, np.zeros(4))
        hist["u_friction"].append(u_fric)
        u = u + u_fric
        u_grav = np.asarray([0.0, 0.0])
        hist["u_gravity"].append(u_grav)
        u = u + u_grav
        hist["u"].append(u)
        return u

    def run(T):
        x, t = np.array([0.3, 0.0, 0.0, 0.0]), 0.0
        ts, xs, us = [], [], []
        while t < T:
            tau = np.clip(control(t, x), -limit, limit)
            k1 = plant.rhs(t, x, tau)
            k2 = plant.rhs(t + 0.5 * dt, x + 0.5 * dt * k1, tau)
            k3 = plant.rhs(t + 0.5 * dt, x + 0.5 * dt * k2, tau)
            k4 = plant.rhs(t + dt, x + dt * k3, tau)
            x = x + dt * (k1 + 2 * (k2 + k3) + k4) / 6.0
            t += dt
            ts.append(t)
            xs.append(x.copy())
            us.append(tau)
        return t

    run(0.2)   # warm up
    t0 = time.perf_counter()
    simulated = run(duration)
    return simulated / (time.perf_counter() - t0)
