"""A real Franka (Panda or FR3) driven through libfranka with franky (``franky-control``):
connect, check, approach, stream a joint reference at 1 kHz under joint impedance, stop.

Streaming. franky's ``JointImpedanceTrackingMotion`` is a client-side joint impedance
controller, the paper's: τ = K (q_d − q) + D (q̇_d − q̇) + coriolis (the robot adds gravity),
with a reference (q_d, q̇_d) it reads anew every control cycle, plus the inertia
feed-forward τ_ff = M(q) q̈_d (libfranka's mass matrix at the measured state), which removes
most of the lag a pure impedance law has behind a moving reference, and a clamped integral
term (``INTEGRAL_TIME_S``, ``INTEGRAL_CLAMP``) against the joints' static friction. Its
per-cycle callback runs in libfranka's 1 kHz control thread with the robot's own clock
(``rel``, seconds since the motion started), so the reference is taken from the plan by
that clock, sample
k = round(rel · rate) + 1 (the next cycle's), not by the wall clock of this process: a
late Python thread cannot stretch or jump the drawing, and a simulator running slower than
real time draws the same motion. The same callback records the robot's reported state
(t, q, q̇, τ_J) of every cycle. q̇_d is the central difference of the plan (exact for the
planner's spline to O(h²)).

Faults. The callback watches |q − q_d| (``GUARD_RAD``): an arm that cannot follow (a
collision, a pen caught on the paper, a simulator without reflexes) is stopped by this
process as a reflex would. The robot's own reflexes and libfranka's errors arrive as
exceptions of ``join_motion``; a lost connection as a NetworkException about a second
later. Ctrl-C and SIGTERM end the motion with franky's ``TorqueStopMotion``, which blends
the last torque into pure joint damping and brings the arm to rest where it is. In every
case :func:`stream` returns what was recorded up to the stop, with the reason, and leaves
the arm stopped; it never raises while the arm moves.

Scheduling. libfranka raises the thread that connects or moves the robot to SCHED_FIFO at
priority 99, and asks for it even under ``RealtimeConfig.Ignore`` (it gets it wherever the
process may, as root). A thread left there starves every other thread on its core, and the
processes it starts afterwards inherit the policy: a worker pool forked or spawned later
busy-waits at priority 99 (the quality benchmark run after a draw in one process went from
19 s to over 15 min). Code that uses the robot therefore runs inside
:func:`scheduling_kept`, which gives the calling thread its own policy back.
"""

from __future__ import annotations

import os
import signal
import threading
import time
import xml.etree.ElementTree as ET
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from inkmotion.errors import InputError, RobotError, ServiceError
from inkmotion.robot.limits import ArmLimits, arm_limits

#: s: how long a connection may take before the robot counts as absent
CONNECT_TIMEOUT_S = 10.0
#: the TCP port of libfranka's FCI (its connection handshake)
FCI_PORT = 1337
#: joint stiffness N·m/rad of libfranka's joint impedance example (stiff shoulder, soft wrist)
STIFFNESS = np.array([600.0, 600.0, 600.0, 600.0, 250.0, 150.0, 50.0])
#: s: integral time of the tracking's integral action (τ_I = K/T_I ∫(q_d − q) dt), and its
#: clamp N·m per joint (anti-windup): it cancels the joints' static friction, which a pure
#: impedance law leaves as an offset of friction/K (~2 mrad, ~1 mm at the pen)
INTEGRAL_TIME_S = 0.1
INTEGRAL_CLAMP = np.array([2.0, 2.0, 2.0, 2.0, 1.0, 1.0, 1.0])
#: rad: the arm is stopped when a joint lags its reference by more than this
GUARD_RAD = 0.05
#: s: the reference is held at its last sample this long before the motion ends
SETTLE_S = 0.3
#: rad: the approach is done when every joint is this close to the start pose
APPROACH_TOLERANCE = 0.003


def _franky() -> Any:
    try:
        import franky
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise RobotError("Driving a Franka needs franky (pip install franky-control, or "
                         "pip install 'inkmotion[robot]'), which is not installed.") from exc
    return franky


@contextmanager
def scheduling_kept() -> Iterator[None]:
    """Run the block, then give the calling thread back the scheduling policy and priority
    it had before (libfranka leaves it at SCHED_FIFO 99; module docstring)."""
    if not hasattr(os, "sched_getscheduler"):  # pragma: no cover - macOS, Windows
        yield
        return
    policy, param = os.sched_getscheduler(0), os.sched_getparam(0)
    try:
        yield
    finally:
        if (os.sched_getscheduler(0), os.sched_getparam(0)) != (policy, param):
            os.sched_setscheduler(0, policy, param)


def _no_answer(host: str, timeout: float, timed_out: bool) -> str:
    """Why nothing answered at ``host``, in one sentence: a name that does not resolve, a
    machine that refuses the connection at once (up, but no FCI listening), or silence."""
    import socket

    try:
        address = socket.getaddrinfo(host, FCI_PORT, type=socket.SOCK_STREAM)[0][4]
    except (socket.gaierror, UnicodeError):
        return (f"The robot's address {host} does not resolve to any machine; give the "
                "FCI's IP (e.g. 172.16.0.2) or a hostname this computer knows.")
    if not timed_out:
        try:
            with socket.create_connection(address[:2], timeout=1.0):
                pass
        except ConnectionRefusedError:
            return (f"The machine at {host} refused the connection at once: it is up, but "
                    "no FCI listens there; activate FCI in Desk (or start the simulator), "
                    "and check that it is the robot's control box.")
        except OSError:
            pass
    return (f"No Franka robot answered at {host} within {timeout:.0f} s; check the address, "
            "the network cable to the robot's control box and that FCI is activated in "
            "Desk.")


def connect(host: str, *, realtime: bool = True,
            timeout: float = CONNECT_TIMEOUT_S) -> Any:
    """A ``franky.Robot`` connected to the FCI at ``host`` within ``timeout`` s; one
    sentence naming the host otherwise. ``realtime=False`` (a simulator, a test bench)
    lets libfranka run without a real-time kernel."""
    franky = _franky()
    config = franky.RealtimeConfig.Enforce if realtime else franky.RealtimeConfig.Ignore
    box: dict[str, Any] = {}

    def attempt() -> None:
        try:
            box["robot"] = franky.Robot(host, realtime_config=config)
        except Exception as exc:  # noqa: BLE001 - reported below, in the caller's thread
            box["error"] = exc

    thread = threading.Thread(target=attempt, name=f"connect {host}", daemon=True)
    thread.start()
    thread.join(timeout)
    if thread.is_alive() or isinstance(box.get("error"), franky.NetworkException):
        raise ServiceError(_no_answer(host, timeout, thread.is_alive()))
    error = box.get("error")
    if isinstance(error, franky.RealtimeException):
        raise RobotError(
            f"libfranka refuses to drive the robot at {host} without a real-time kernel "
            f"({error}); boot a PREEMPT_RT kernel (see the README), or pass --realtime "
            "ignore only for a simulator or a test bench.")
    if isinstance(error, franky.IncompatibleVersionException):
        raise RobotError(f"The robot at {host} speaks another FCI version than this "
                         f"libfranka ({error}); install the franky-control release that "
                         "matches the robot's system version.")
    if error is not None:
        raise RobotError(f"Connecting to the robot at {host} failed: {error}; check the "
                         "robot's state in Desk (unlocked, FCI active) and try again.")
    return box["robot"]


def connected_arm(robot: Any, model: str = "auto") -> ArmLimits:
    """The connected arm's limits: its model (FR3 or Panda, from the URDF the robot
    reports, or ``model`` when given) with the position and velocity ranges of that URDF
    where they are narrower than the datasheet's."""
    try:
        urdf = str(robot.model_urdf)
    except Exception:  # noqa: BLE001 - older system versions do not serve the URDF
        urdf = ""
    names, lower, upper, velocity = _urdf_arm_joints(urdf)
    if model == "auto":
        model = _urdf_model(urdf, names)
    base = arm_limits(model)
    if not names:
        return base
    return ArmLimits(base.name, lower=np.maximum(base.lower, lower),
                     upper=np.minimum(base.upper, upper),
                     velocity=np.minimum(base.velocity, velocity),
                     acceleration=base.acceleration, jerk=base.jerk, torque=base.torque)


def _urdf_model(urdf: str, joints: list[str]) -> str:
    """"fr3" or "panda" from the URDF's robot name or its joints' prefix."""
    try:
        robot_name = ET.fromstring(urdf).get("name", "") if urdf.strip() else ""
    except ET.ParseError:
        robot_name = ""
    for label in [robot_name.lower()] + [j.lower() for j in joints]:
        if "fr3" in label:
            return "fr3"
        if "panda" in label:
            return "panda"
    raise RobotError("The robot does not say which Franka it is (no model in the URDF its FCI "
                     "serves); name it with --model fr3 or --model panda.")


def _urdf_arm_joints(urdf: str) -> tuple[list[str], np.ndarray, np.ndarray, np.ndarray]:
    """Names and (lower, upper, velocity) limits of the seven revolute arm joints of a URDF
    (empty when there are not exactly seven)."""
    empty = ([], np.zeros(7), np.zeros(7), np.zeros(7))
    if not urdf.strip():
        return empty
    try:
        root = ET.fromstring(urdf)
    except ET.ParseError:
        return empty
    rows = []
    for joint in root.iter("joint"):
        name = joint.get("name", "")
        limit = joint.find("limit")
        if joint.get("type") != "revolute" or limit is None:
            continue
        if not any(name.endswith(f"joint{i}") for i in range(1, 8)):
            continue
        rows.append((name, float(limit.get("lower", "nan")), float(limit.get("upper", "nan")),
                     float(limit.get("velocity", "inf"))))
    if len(rows) != 7:
        return empty
    rows.sort(key=lambda r: r[0][-1])
    arr = np.array([r[1:] for r in rows])
    return [r[0] for r in rows], arr[:, 0], arr[:, 1], arr[:, 2]


def joint_positions(robot: Any) -> np.ndarray:
    """The arm's measured joint positions (7,) rad."""
    return np.asarray(robot.current_joint_positions, dtype=float)


def check_start(q_now: np.ndarray, q_start: np.ndarray, arm: ArmLimits,
                max_approach: float) -> None:
    """Refuse to move when the arm is outside its own ranges or farther than
    ``max_approach`` rad (any joint) from the plan's start pose."""
    outside = (q_now < arm.lower) | (q_now > arm.upper)
    if outside.any():
        j = int(np.flatnonzero(outside)[0])
        raise RobotError(f"The arm's joint {j + 1} is at {q_now[j]:.3f} rad, outside the "
                         f"{arm.name}'s range; guide it back inside in Desk first.")
    far = np.abs(q_now - q_start)
    if far.max() > max_approach:
        j = int(np.argmax(far))
        raise InputError(
            f"The arm is {far[j]:.2f} rad from the drawing's start pose at joint {j + 1} "
            f"(allowed {max_approach:.2f} rad); move it near the setup's home pose first, "
            "or raise --max-approach.")


def approach(robot: Any, q_start: np.ndarray, dynamics_factor: float,
             settle_s: float = 3.0) -> float:
    """Move to ``q_start`` with franky's own time-optimal joint motion at
    ``dynamics_factor`` of its velocity, acceleration and jerk limits, then wait until
    every joint is within ``APPROACH_TOLERANCE``; returns the seconds it took."""
    franky = _franky()
    started = time.perf_counter()
    robot.move(franky.JointMotion(np.asarray(q_start, dtype=float),
                                  relative_dynamics_factor=float(dynamics_factor)))
    deadline = time.perf_counter() + settle_s
    while np.abs(joint_positions(robot) - q_start).max() > APPROACH_TOLERANCE:
        if time.perf_counter() > deadline:
            off = np.abs(joint_positions(robot) - q_start).max()
            raise RobotError(f"The arm did not settle at the drawing's start pose ({off:.4f} "
                             f"rad off after {settle_s:.0f} s); check for a collision or a "
                             "load and run again.")
        time.sleep(0.01)
    return time.perf_counter() - started


@dataclass
class Execution:
    """What the robot reported, one row per control cycle, and how the motion ended."""

    t: np.ndarray  # (N,) s, the robot's clock since the motion started
    q: np.ndarray  # (N, 7) rad
    dq: np.ndarray  # (N, 7) rad/s
    tau: np.ndarray  # (N, 7) N·m, measured joint torques
    q_ref: np.ndarray  # (N, 7) rad, the reference sent in that cycle
    completed: bool
    stop_reason: str | None  # None when completed
    wall_s: float
    info: dict = field(default_factory=dict)

    @property
    def duration(self) -> float:
        return float(self.t[-1]) if len(self.t) else 0.0


class _Stream:
    """The per-cycle callback: the plan's next sample by the robot's clock, the record."""

    def __init__(self, motion: Any, q_plan: np.ndarray, rate: float, franky: Any,
                 model: Any = None) -> None:
        self.motion, self.q_plan, self.rate, self.franky = motion, q_plan, rate, franky
        self.model = model
        self.gain_i = STIFFNESS / INTEGRAL_TIME_S
        self.integral = np.zeros(7)
        self.last_t = 0.0
        self.dq_plan = np.gradient(q_plan, 1.0 / rate, axis=0)
        self.dq_plan[0] = self.dq_plan[-1] = 0.0
        self.ddq_plan = np.gradient(self.dq_plan, 1.0 / rate, axis=0)
        capacity = len(q_plan) + int((SETTLE_S + 5.0) * rate)
        self.t = np.zeros(capacity)
        self.q = np.zeros((capacity, 7))
        self.dq = np.zeros((capacity, 7))
        self.tau = np.zeros((capacity, 7))
        self.ref = np.zeros((capacity, 7))
        self.count = 0
        self.sample = 0
        self.fault: str | None = None
        self.frozen = False

    @property
    def finished(self) -> bool:
        return self.sample >= len(self.q_plan) - 1 and \
            self.t[max(self.count - 1, 0)] >= (len(self.q_plan) - 1) / self.rate + SETTLE_S

    def __call__(self, state: Any, dt: Any, rel: Any, absolute: Any, signal_: Any) -> None:
        t = rel.to_sec()
        q = np.asarray(state.q)
        k = min(int(round(t * self.rate)), len(self.q_plan) - 1)
        i = self.count
        if i < len(self.t):
            self.t[i], self.q[i], self.dq[i] = t, q, np.asarray(state.dq)
            self.tau[i], self.ref[i] = np.asarray(state.tau_J), self.q_plan[k]
            self.count = i + 1
        if self.frozen:
            return
        lag = float(np.abs(q - self.q_plan[k]).max())
        if lag > GUARD_RAD and self.fault is None:
            j = int(np.argmax(np.abs(q - self.q_plan[k])))
            self.fault = (f"joint {j + 1} lagged its reference by {lag:.3f} rad at t = "
                          f"{t:.3f} s (a collision, a caught pen or a reflex)")
            self.frozen = True
            return
        nxt = min(k + 1, len(self.q_plan) - 1)
        self.sample = nxt
        step, self.last_t = max(t - self.last_t, 0.0), t
        self.integral = np.clip(self.integral + self.gain_i * (self.q_plan[k] - q) * step,
                                -INTEGRAL_CLAMP, INTEGRAL_CLAMP)
        tau_ff = self.integral.copy()
        if self.model is not None:
            tau_ff += self.model.mass(state) @ self.ddq_plan[nxt]
        self.motion.set_reference(self.franky.JointReference(
            q=self.q_plan[nxt], dq=self.dq_plan[nxt], tau_ff=tau_ff))

    def execution(self, completed: bool, reason: str | None, wall_s: float) -> Execution:
        n = self.count
        return Execution(self.t[:n].copy(), self.q[:n].copy(), self.dq[:n].copy(),
                         self.tau[:n].copy(), self.ref[:n].copy(), completed, reason, wall_s)


def _stop_smoothly(robot: Any, franky: Any) -> str | None:
    """End the torque loop with a TorqueStopMotion (the arm brought to rest where it is);
    the error text when even that fails (the robot then stops by its own reflex)."""
    try:
        robot.move(franky.TorqueStopMotion(), asynchronous=True)
        robot.join_motion()
    except Exception as exc:  # noqa: BLE001 - the caller reports it with the stop
        return str(exc)
    return None


def stream(robot: Any, q_plan: np.ndarray, rate: float, *,
           stiffness: np.ndarray = STIFFNESS, damping: np.ndarray | None = None,
           feedforward: bool = True,
           on_progress: Callable[[float], None] | None = None) -> Execution:
    """Track ``q_plan`` (N, 7) at ``rate`` Hz under joint impedance (module docstring) and
    return the robot's record; never raises while the arm moves: a fault, Ctrl-C or
    SIGTERM ends the motion smoothly and is returned as ``stop_reason``."""
    franky = _franky()
    q_plan = np.asarray(q_plan, dtype=float)
    motion = franky.JointImpedanceTrackingMotion(
        stiffness=np.asarray(stiffness, float),
        damping=None if damping is None else np.asarray(damping, float))
    motion.set_reference(franky.JointReference(q=q_plan[0], dq=np.zeros(7)))
    recorder = _Stream(motion, q_plan, rate, franky, robot.model if feedforward else None)
    motion.register_callback(recorder)
    previous: dict[int, Any] = {}

    asked: list[str] = []

    def signalled(signum: int, frame: Any) -> None:
        # noted, not raised: franky's join_motion checks for Python signals and would turn
        # an exception into its own preemption of the motion
        asked.append("interrupted (Ctrl-C)" if signum == signal.SIGINT
                     else "stopped by SIGTERM")
    started = time.perf_counter()
    reason: str | None = None
    running = False
    try:
        robot.move(motion, asynchronous=True)
        running = True
        if threading.current_thread() is threading.main_thread():
            # a Ctrl-C or SIGTERM must stop the arm smoothly and say so
            for signum in (signal.SIGINT, signal.SIGTERM):
                previous[signum] = signal.signal(signum, signalled)
        last = -1.0
        while True:
            if robot.join_motion(timeout=0.02):
                running = False
                reason = "the robot ended the motion by itself"
                break
            if asked:
                reason = asked[0]
                break
            if recorder.fault is not None:
                reason = recorder.fault
                break
            if recorder.finished:
                break
            now = recorder.t[max(recorder.count - 1, 0)]
            if on_progress is not None and now - last >= 0.5:
                on_progress(now)
                last = now
    except KeyboardInterrupt:
        reason = "interrupted (Ctrl-C)"
    except franky.NetworkException as exc:
        running = False
        reason = f"the connection to the robot was lost ({exc})"
    except (franky.ControlException, franky.CommandException, RuntimeError) as exc:
        running = False
        reason = f"libfranka stopped the motion ({exc})"
    finally:
        recorder.frozen = True
        if running:
            problem = _stop_smoothly(robot, franky)
            if problem is not None and reason is not None:
                reason += f"; stopping failed too ({problem})"
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        # the motion holds the recorder (its callback, in C++) and the recorder the motion:
        # a cycle Python's collector cannot see, which kept every drawing's record (tens of
        # MB) alive for the rest of a worker's life. The frozen recorder no longer reads it.
        recorder.motion = None
    return recorder.execution(reason is None, reason, time.perf_counter() - started)


def recover(robot: Any) -> bool:
    """Clear the robot's errors (libfranka's automatic error recovery); True on success."""
    try:
        return bool(robot.recover_from_errors())
    except Exception:  # noqa: BLE001 - reported by the caller as "not recovered"
        return False
