"""Options of the commands that read a robot's logs (``replay``,
``calibrate``): the log's column names, its angles, its torque's sign and
a stretch of its clock; and the logs read with them."""
from __future__ import annotations

from .common import InputError, _floats
from .options import option


def add_log_options(p) -> None:
    """Declare ``--columns``, ``--angles``, ``--torque-sign`` and ``--span`` on ``p``."""
    option(p, "--columns", str, None, "the log's names of its columns, e.g. "
           "t=meas_time,q1=shoulder_meas_pos,q2=elbow_meas_pos,tau=elbow_meas_tau "
           "(names: t, q1, q2, q1d, q2d, tau, i_cmd)")
    p.add_argument("--angles", choices=("package", "robot"), default="package",
                   help="the log's angles, rates and torque are the package's, or the joint "
                   "coordinates of the robot description (robot.file)")
    option(p, "--torque-sign", float, 1.0, "1, or -1 when the log's torque sign is the "
           "opposite of the model's")
    option(p, "--span", str, None, "START,END: use this stretch of the log's clock (s)")


def read_logs(args, params, paths, torque: bool = True):
    """The logs at ``paths`` read with the log options of ``args`` (checked;
    ``torque = False``: the angles alone will do)."""
    from ..analysis.identification.calibration import in_package_angles, read_calibration_csv

    if args.torque_sign not in (-1.0, 1.0):
        raise InputError(f"--torque-sign = {args.torque_sign:g} must be 1 or -1")
    description = None
    if args.angles == "robot":
        if not params.robot.file:
            raise InputError("--angles robot needs a robot description (robot.file); "
                             "allowed: package without one")
        from ..params.robot_file import describe_robot

        description = describe_robot(params.robot)
    columns, span = _columns(args.columns), _span(args.span)
    logs = []
    for path in paths:
        log = read_calibration_csv(path, params.motor.torque_per_amp, min_duration=0.2,
                                   torque_sign=args.torque_sign, columns=columns, span=span,
                                   torque=torque)
        logs.append(log if description is None else in_package_angles(log, description))
    return logs


def _columns(text):
    """``--columns`` as {our name: the file's}: ``t=meas_time,q1=...``."""
    if not text:
        return None
    out = {}
    for item in text.split(","):
        ours, eq, theirs = (s.strip() for s in item.partition("="))
        if not (eq and ours and theirs):
            raise InputError(f"--columns '{item}' must be name=column (e.g. t=meas_time)")
        out[ours] = theirs
    return out


def _span(text):
    """``--span START,END`` (s of the log's clock) as a pair."""
    if not text:
        return None
    start, end = _floats(text, 2, "--span")
    if not start < end:
        raise InputError(f"--span {text}: allowed START < END (s)")
    return start, end
