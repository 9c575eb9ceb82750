"""Two planar IMUs (chapter 5, Table 5.1) on Drake's Gyroscope/Accelerometer.

IMU i sits on link i at distance ``r_i`` from the link's proximal joint.  Its
body frame: ``x`` tangential (positive toward increasing theta_i), ``y``
along the link toward the proximal joint, which is the link's own body frame
in :mod:`bplir_drake.systems.plant`.  The accelerometer reads specific force
(hanging at rest ``mu_y = +g``), the gyro the absolute rate ``omega_i``.

Drake's sensors give continuous signals; :class:`ImuSampler` samples them
with a zero-order hold at the IMU rate (which also breaks the accelerometer's
direct feedthrough from the actuation input) and adds, per Table 5.1 and
(5.21)-(5.22), (5.38): white noise, constant gyro bias, gyro bias random walk,
accelerometer misalignment and scale error.  The draws of a swing are made
per swing, not per tick: sample ``k``'s come from row ``k mod 256`` of block
``k // 256`` of :func:`noise_block` (``numpy.random.default_rng((seed, 4,
block))``), so a run is reproducible from its seed alone.

Output order (also the CSV log order): ``gyro1, gyro2, acc1_x, acc1_y,
acc2_x, acc2_y``.
"""
from __future__ import annotations

import math
from dataclasses import replace
from functools import lru_cache

import numpy as np
from numba import njit
from pydrake.common.containers import namedview
from pydrake.common.value import AbstractValue

from .pysystem import PySystem
from ..params import ImuParams
from .schedule import declare_sample

IMU_COLUMNS = ("gyro1", "gyro2", "acc1_x", "acc1_y", "acc2_x", "acc2_y")
#: the sampler's held state: the sample, the two gyro bias walks, the next sample's index
SAMPLER_FIELDS = (*IMU_COLUMNS, "walk1", "walk2", "index")
SAMPLER_WALK1, SAMPLER_WALK2 = SAMPLER_FIELDS.index("walk1"), SAMPLER_FIELDS.index("walk2")


def imu_kinematics(theta, omega, omega_dot, r1: float, r2: float, l1: float, g: float):
    """Noise-free IMU readings from absolute angles, rates and accelerations.

    From differentiating (5.6)-(5.7) twice and (5.9):
    ``mu1 = (r1 w1' + g s1, r1 w1^2 + g c1)`` and
    ``mu2x = l1 (w1' c21 + w1^2 s21) + r2 w2' + g s2``,
    ``mu2y = l1 (-w1' s21 + w1^2 c21) + r2 w2^2 + g c2`` with
    ``c21 = cos(theta2 - theta1)``, ``s21 = sin(theta2 - theta1)``.
    """
    t1, t2 = theta
    w1, w2 = omega
    a1, a2 = omega_dot
    s1, c1, s2, c2 = math.sin(t1), math.cos(t1), math.sin(t2), math.cos(t2)
    s21, c21 = math.sin(t2 - t1), math.cos(t2 - t1)
    return np.array([
        w1, w2,
        r1 * a1 + g * s1, r1 * w1 ** 2 + g * c1,
        l1 * (a1 * c21 + w1 ** 2 * s21) + r2 * a2 + g * s2,
        l1 * (-a1 * s21 + w1 ** 2 * c21) + r2 * w2 ** 2 + g * c2,
    ])


def corrupt(ideal, params: ImuParams, bias, rng) -> np.ndarray:
    """Apply misalignment, scale errors, gyro bias and white noise to one sample.

    ``ideal`` is the noise-free 6-vector, ``bias`` the current gyro bias
    (constant + random walk).
    """
    out = np.array(ideal, dtype=float)
    for i, (eps, scale) in enumerate(((params.misalign1, params.accel_scale1),
                                      (params.misalign2, params.accel_scale2))):
        mx, my = out[2 + 2 * i], out[3 + 2 * i]
        c, s = math.cos(eps), math.sin(eps)
        # sensor axes rotated by eps about z relative to the link frame
        out[2 + 2 * i] = (1.0 + scale) * (c * mx + s * my)
        out[3 + 2 * i] = (1.0 + scale) * (-s * mx + c * my)
    out[0] *= 1.0 + params.gyro_scale1
    out[1] *= 1.0 + params.gyro_scale2
    out[0:2] += bias
    if params.noise:
        out += noise_sigmas(params) * rng.standard_normal(6)
    return out


def noise_sigmas(params: ImuParams) -> np.ndarray:
    """The white noise's standard deviation per IMU column (gyros, then
    accelerometers)."""
    return np.array([params.gyro_sigma] * 2 + [params.accel_sigma] * 4)


def standstill_samples(params: ImuParams, theta, g: float, seed: int, n: int) -> np.ndarray:
    """``n`` samples (n, 6) of the IMUs with the robot held still at the
    absolute link angles ``theta`` (rad): gravity ``g`` in each link frame,
    through the sensors' errors (:func:`corrupt`, constant gyro bias) with
    noise drawn at once from ``default_rng((seed, 3))`` -- a stream of its
    own, so the swing's samples do not change.  The simulated sensor before
    a swing."""
    ideal = imu_kinematics(theta, (0.0, 0.0), (0.0, 0.0), params.r1, params.r2, 0.0, g)
    bias = np.array([params.gyro_bias1, params.gyro_bias2])
    # the noise-free reading is the same for every sample: corrupt it once
    still = corrupt(ideal, replace(params, noise=False), bias, None)
    if not params.noise:
        return np.tile(still, (n, 1))
    draws = np.random.default_rng((seed, 3)).standard_normal((n, 6))
    return still + noise_sigmas(params) * draws


#: ticks per block of drawn noise (:func:`noise_block`)
NOISE_BLOCK = 256


@lru_cache(maxsize=8)
def noise_block(seed: int, block: int) -> np.ndarray:
    """The standard normal draws of ticks ``256 block .. 256 block + 255`` of
    the sensors seeded by ``seed`` (256, 8): per tick the two gyro bias
    walks' steps, then the six readings' white noise (read-only)."""
    out = np.random.default_rng((seed, 4, block)).standard_normal((NOISE_BLOCK, 8))
    out.flags.writeable = False
    return out


def pack(params: ImuParams) -> np.ndarray:
    """The error model of ``params`` for :func:`sample_kernel`: misalignment
    and scale error per accelerometer, gyro scale errors and constant biases,
    the bias walk per sample, whether white noise is on, the white noise per
    column."""
    return np.array([params.misalign1, params.accel_scale1, params.misalign2,
                     params.accel_scale2, params.gyro_scale1, params.gyro_scale2,
                     params.gyro_bias1, params.gyro_bias2,
                     params.gyro_drift * math.sqrt(params.period), float(params.noise),
                     *noise_sigmas(params)])


@njit(cache=True)
def sample_kernel(g1, g2, a1x, a1y, a2x, a2y, walk1, walk2, k, c, draws):
    """The held state after sample ``k`` (the 6 readings, the two bias walks,
    ``k + 1``) from the ideal readings, the walks so far, the packed error
    model ``c`` (:func:`pack`) and the tick's draws (8): :func:`corrupt`
    with the walk stepped first."""
    out = np.empty(9)
    if c[8] > 0.0:
        walk1 += c[8] * draws[0]
        walk2 += c[8] * draws[1]
    ideal = (a1x, a1y, a2x, a2y)
    for i in range(2):
        eps, scale = c[2 * i], c[2 * i + 1]
        mx, my = ideal[2 * i], ideal[2 * i + 1]
        ce, se = math.cos(eps), math.sin(eps)
        out[2 + 2 * i] = (1.0 + scale) * (ce * mx + se * my)
        out[3 + 2 * i] = (1.0 + scale) * (-se * mx + ce * my)
    out[0] = g1 * (1.0 + c[4]) + (c[6] + walk1)
    out[1] = g2 * (1.0 + c[5]) + (c[7] + walk2)
    if c[9] > 0.0:
        for i in range(6):
            out[i] += c[10 + i] * draws[2 + i]
    out[6], out[7], out[8] = walk1, walk2, k + 1.0
    return out


class ImuSampler(PySystem):
    """Samples Drake's four sensor outputs at the IMU rate (zero-order hold).

    Inputs ``gyro1``, ``gyro2`` (angular velocity in the sensor frame) and
    ``accel1``, ``accel2`` (specific force in the sensor frame); output
    ``imu`` (6).  Discrete state :data:`ImuSampler.State`: the held sample,
    the gyro bias walk and the sample index.  Sample ``k`` is taken at
    ``t_k = k T`` (:func:`~bplir_drake.systems.schedule.declare_sample`).

    The error model and the noise seed are an abstract parameter of the
    context, ``(ImuParams, seed)`` (default: the constructor's), so one
    built diagram serves sensors of other Monte Carlo samples
    (:meth:`set_sensor`); only the rate is fixed at construction.
    """

    State = namedview("ImuSamplerState", SAMPLER_FIELDS)

    def __init__(self, params: ImuParams, seed: int = 0):
        super().__init__()
        self.params = params
        self.seed = int(seed)
        self.gyro_ports = [self.DeclareVectorInputPort(f"gyro{i}", 3) for i in (1, 2)]
        self.accel_ports = [self.DeclareVectorInputPort(f"accel{i}", 3) for i in (1, 2)]
        #: the built sensor parameter ``(params, seed, packed)`` (a context's default)
        self.sensor = (params, self.seed, pack(params))
        self._sensor = self.DeclareAbstractParameter(AbstractValue.Make(self.sensor))
        self._state = self.DeclareDiscreteState(len(self.State._fields))
        declare_sample(self, params.period, self._sample)
        self.imu_port = self.DeclareVectorOutputPort("imu", 6, self._output, {self.xd_ticket()})

    def set_sensor(self, context, params: ImuParams, seed: int) -> None:
        """The error model and noise seed of the sensors in ``context`` (the
        root context); ``params.period`` must be the built one."""
        own = self.GetMyMutableContextFromRoot(context)
        own.get_mutable_abstract_parameter(self._sensor).set_value(
            self.sensor_of(params, seed))

    def sensor_of(self, params: ImuParams, seed: int) -> tuple:
        """The sensor parameter ``(params, seed, packed)`` of sensors with the
        error model ``params`` and noise seed ``seed``; ``params.period``
        must be the built one."""
        if params.period != self.params.period:
            raise ValueError(f"imu.rate_hz = {params.rate_hz:g} differs from the built "
                             f"sampler's {self.params.rate_hz:g} Hz")
        return (params, int(seed), pack(params))

    def _sample(self, context, discrete_state):
        g1, g2 = (port.Eval(context) for port in self.gyro_ports)
        a1, a2 = (port.Eval(context) for port in self.accel_ports)
        discrete_state.set_value(self._state, self.next_state(
            context.get_discrete_state(self._state).get_value(),
            g1[2], g2[2], a1[0], a1[1], a2[0], a2[1],
            context.get_abstract_parameter(self._sensor).get_value()))

    @staticmethod
    def next_state(s, g1, g2, a1x, a1y, a2x, a2y, sensor):
        """The held state after the next sample (:data:`State`) from the
        held state ``s``, the ideal readings the planar model uses (each
        gyro's z rate, each accelerometer's x and y) and the sensor
        parameter ``(params, seed, packed)``."""
        _, seed, consts = sensor
        k, draws = ImuSampler.sample_draws(s, seed)
        return sample_kernel(g1, g2, a1x, a1y, a2x, a2y, s[6], s[7], k, consts, draws)

    @staticmethod
    def sample_draws(s, seed: int):
        """(the index of the next sample, its noise draws: a row of
        :func:`noise_block`) from the held state ``s`` and the noise seed."""
        k = int(s[8] + 0.5)   # a count held as a float
        return k, noise_block(seed, k // NOISE_BLOCK)[k % NOISE_BLOCK]

    def _output(self, context, out):
        out.SetFromVector(context.get_discrete_state(self._state).get_value()[:6])
