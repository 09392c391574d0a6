"""The served controller: the state an IRC5 keeps (motors, operation mode, the loaded task,
the program pointer, execution, speed ratio, I/O, event log) over the cell's controller API,
and the one thread that moves the cell.

The cell is moved by one worker thread only: a RAPID program started by a client runs there
on the executor `twincell execute` uses (planned on the nominal arm when the program pointer
is reset: scenarios.rapid.planner; then run move by move: scenarios.rapid.executor), and so
does the streaming of an external guidance (EGM). Requests from clients never touch the cell:
they read the snapshot the worker publishes every 4 ms of the controller's time (encoders,
flange, table, tool) and hand commands to the worker.

Time: the worker paces the cell's simulated time to the wall clock (`speed` times faster),
so that clients that poll and time out see a controller's timing. Time runs while something
moves or EGM streams; an idle arm stands still, and the clock is locked again at the next
motion. When the cell cannot keep up, the event log says so.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from cell import CellError, Controller, MotionHaltedError, SupervisionError
from scenarios.rapid.execution_plan import ExecutionPlan
from scenarios.rapid.executor import (
    ExecutedMove,
    ExecutionError,
    ExecutionRecord,
    run_move,
    start_plan,
)
from scenarios.rapid.module import RapidModule
from scenarios.rapid.planner import cell_tools, plan_execution
from scenarios.rapid.syntax import RapidError
from scenarios.twin.cell_io import DEVICE_OUTPUTS, CellIo
from scenarios.twin.controller_errors import ControllerError, bad_request, not_allowed
from scenarios.twin.elog import EventLog
from scenarios.twin.file_service import FileService
from scenarios.twin.guidance import PERIOD_S, Guidance
from scenarios.twin.pacing import StandingTicks, WallClockPacer
from scenarios.twin.sensor_streams import SensorStreams
from scenarios.twin.signals import SignalSpec, parse_value
from scenarios.twin.snapshot import Snapshot
from scenarios.twin.symbols import Symbol
from scenarios.twin.task_modules import TaskModules

#: The operation modes the twin runs in: automatic, and manual reduced speed (where a
#: remote client reads but neither starts programs nor writes: on an IRC5 that needs the
#: FlexPendant, or remote mastership its user grants there).
OPMODES = ("AUTO", "MANR")


@dataclass
class Execution:
    """The program pointer: the plan it points into, the next move (-1: before the tool
    change and the start move), and the moves done since the pointer was reset."""

    plan: ExecutionPlan
    next_move: int = -1
    done: list[ExecutedMove] = field(default_factory=list)
    start_time_s: float = 0.0


Listener = Callable[[str, str], None]


class TwinController:
    """The served controller over the cell's `controller` (its nominal arm moving: an IRC5
    without absolute accuracy). `folder` holds its file system and loaded task;
    `on_touch(target)` hears each touch of a program, `on_end(record)` each program that
    ran to its end; `say` prints progress."""

    def __init__(
        self,
        controller: Controller,
        folder: Path,
        speed: float = 1.0,
        on_touch: Callable[[str, str | None], None] | None = None,
        on_end: Callable[[ExecutionRecord], None] | None = None,
        say: Callable[[str], None] | None = None,
        opmode: str = "AUTO",
    ) -> None:
        if not speed > 0:
            raise bad_request(f"speed {speed!r}: give a factor > 0")
        if opmode not in OPMODES:
            raise bad_request(f"operation mode {opmode!r}: give {' or '.join(OPMODES)}")
        self.cell = controller
        self.files = FileService(folder / "files")
        self.elog = EventLog()
        #: The modules loaded into T_ROB1.
        self.task = TaskModules(folder / "task", self.elog)
        self.ctrlstate = "motoron"
        self.opmode = opmode
        self.execstate = "stopped"
        self.cycle = "once"
        self.speedratio = 100
        #: Hear every state change: (resource, value), e.g. ("execution", "running").
        self.listeners: list[Listener] = []
        self._on_touch = on_touch or (lambda _t, _tool: None)
        self._on_end = on_end or (lambda _r: None)
        self._say = say or (lambda _m: None)
        self._lock = threading.RLock()
        self._execution: Execution | None = None
        self._commands: queue.Queue[Callable[[], None]] = queue.Queue()
        self._halt = threading.Event()
        #: A tool change runs: a client's stop waits for its end (halted in the rack, the arm
        #: would leave it by a joint move through the tools beside the slot).
        self._changing_tool = False
        self._closing = threading.Event()
        self.pacer = WallClockPacer(speed, controller.time_s, self._lagging)
        self._standing = StandingTicks(PERIOD_S)
        #: The I/O signals and the devices behind them.
        self.io = CellIo(
            controller, self.elog, self.submit, self.pacer.relock, self._refresh, self._changed
        )
        #: What streams every control period (EGM feedback, the laser's profiles), and the
        #: EGM guidance (None: no EGM session); set by the server.
        self.streams = SensorStreams()
        self.guidance: Guidance | None = None
        q = controller.read_joints()
        self._q_ref = q
        self.snapshot = self._snapshot(q, q)
        controller.pace(self._clock)
        self.elog.add("motors_on", "the controller started with its motors on")
        self._worker = threading.Thread(target=self._work, name="twin-motion", daemon=True)
        self._worker.start()

    # -- the worker --------------------------------------------------------------------------
    def _work(self) -> None:
        guided = False
        while not self._closing.is_set():
            follow = self.guidance is not None and self.guidance.fresh()
            streaming = follow or self.streams.streaming
            command: Callable[[], None]
            try:
                if follow:
                    command = self._commands.get_nowait()
                else:
                    command = self._commands.get(
                        timeout=self._standing.wait_s() if streaming else 0.05
                    )
                guided = False
            except queue.Empty:
                if not streaming:
                    continue
                if follow and not guided:
                    self.pacer.relock(self.cell.time_s)
                guided = follow
                command = self._egm_tick if follow else self._stand_tick
            try:
                command()
            except MotionHaltedError:
                pass  # a stop asked while streaming, or the server closing
            except Exception as exc:  # the worker serves on after any error
                self.elog.add("execution_error", f"the controller's worker: {exc!r}")

    def submit(self, command: Callable[[], None]) -> None:
        """Run `command` on the worker (the only thread that moves the cell)."""
        self._commands.put(command)

    def close(self) -> None:
        """Halt what moves and end the worker."""
        self._halt.set()
        self._closing.set()
        self._worker.join(timeout=10.0)
        self.cell.pace(None)

    def _clock(self, time_s: float) -> str | None:
        """Every 4 ms of the controller's time while the cell moves: publish a snapshot,
        stream EGM feedback, keep pace with the wall clock, halt on a stop request."""
        q = self.cell.read_joints()
        self.snapshot = self._snapshot(q, self._q_ref, time_s)
        self._publish(moving=True)
        self.pacer.keep_pace(time_s)
        self._standing.follow_on()
        if self._halt.is_set() and not self._finish_tool_change():
            return "stop requested by a client"
        return None

    def _finish_tool_change(self) -> bool:
        """Whether a stop waits for the tool change to end (not for motors off or closing)."""
        return self._changing_tool and not (self.ctrlstate == "motoroff" or self._closing.is_set())

    def _stand_tick(self) -> None:
        """A control period standing still (on the worker): the encoders read anew and the
        streams fed; the controller's time stands."""
        self.snapshot = self._snapshot(self.cell.read_joints(), self._q_ref)
        self._publish(moving=False)
        self._standing.ticked()

    def _publish(self, moving: bool) -> None:
        motors_on, running = self.ctrlstate == "motoron", self.execstate == "running"
        self.streams.publish(self.cell, self.snapshot, motors_on, running, moving)
        self.io.values["aiLaserRange"] = self.streams.laser_mm

    def _lagging(self, message: str) -> None:
        self.elog.add("lagging", message)
        self._say(message)

    def _snapshot(self, q: np.ndarray, q_ref: np.ndarray, time_s: float | None = None) -> Snapshot:
        cell = self.cell
        return Snapshot(
            cell.time_s if time_s is None else time_s,
            q,
            np.array(q_ref, dtype=float),
            cell.kinematics.fk(q),
            cell.table_position(),
            cell.tool_in_hand,
            self.streams.egm is not None and cell.read_beam(),  # streamed with EGM only
            cell.read_ir() if cell.tool_in_hand == "ir" else None,
        )

    def _refresh(self) -> None:
        """A snapshot after a command that did not move (on the worker); the cell's inputs
        are read from it (`signal`)."""
        self.snapshot = self._snapshot(self.cell.read_joints(), self._q_ref)

    # -- state --------------------------------------------------------------------------------
    def _changed(self, resource: str, value: str) -> None:
        for listener in list(self.listeners):
            listener(resource, value)

    def set_ctrlstate(self, state: str) -> None:
        """Motors on or off (`motoron`, `motoroff`); motors off halts a running program."""
        self.require_auto("switch the motors")
        if state not in ("motoron", "motoroff"):
            raise bad_request(f"ctrl-state {state!r}: give motoron or motoroff")
        with self._lock:
            if state == self.ctrlstate:
                return
            if state == "motoroff" and self.execstate == "running":
                self._halt.set()
            self.ctrlstate = state
        self.elog.add("motors_on" if state == "motoron" else "motors_off", f"motors {state[5:]}")
        self._changed("ctrlstate", state)

    def set_speedratio(self, ratio: float) -> None:
        if not 0 <= ratio <= 100:
            raise bad_request(f"speed-ratio {ratio!r}: give 0 to 100 [%]")
        if ratio != 100:
            raise not_allowed(
                f"speed-ratio {ratio:g}: the twin runs programs at 100 % only (a lower ratio "
                "would change the motion the program's figures were planned for)"
            )
        self.speedratio = int(ratio)

    # -- the task -----------------------------------------------------------------------------
    def modules(self) -> list[RapidModule]:
        """The loaded modules, as read now."""
        return self.task.modules()

    def module_names(self) -> list[str]:
        return self.task.names()

    def load_module(self, path: str, replace: bool = False) -> str:
        """Load the module file `path` (a file-service path) into T_ROB1; refused, with an
        event-log entry and nothing moved, if it does not read."""
        self.require_auto("load a module")
        data = self.files.read(path)
        self._require_stopped("load a module")
        with self._lock:
            name = self.task.load(data, path, replace)
            self._execution = None
        return name

    def unload_module(self, name: str) -> None:
        self.require_auto("unload a module")
        self._require_stopped("unload a module")
        with self._lock:
            self.task.unload(name)
            self._execution = None

    def symbol(self, path: str) -> Symbol:
        return self.task.symbol(path)

    def set_symbol(self, path: str, value: str) -> None:
        """Write a RAPID datum (the loaded module's text changes; the program reads it at the
        next program pointer reset)."""
        self.require_auto("write RAPID data")
        symbol = self.task.set_symbol(path, value)
        self._changed(f"rapid:{symbol.url}", symbol.value)

    # -- execution ------------------------------------------------------------------------------
    def require_auto(self, what: str) -> None:
        if self.opmode != "AUTO":
            raise not_allowed(
                f"cannot {what} in manual mode ({self.opmode}): a remote client does so in "
                "automatic mode (an IRC5 in manual mode takes it from the FlexPendant)"
            )

    def _require_stopped(self, what: str) -> None:
        if self.execstate == "running":
            raise not_allowed(f"cannot {what} while the program runs (stop it first)")

    def resetpp(self) -> None:
        """Plan the loaded task from main on the nominal arm, from where the arm stands (the
        data as they are now); a program that cannot run is refused here, with an event-log
        entry."""
        self.require_auto("reset the program pointer")
        self._require_stopped("reset the program pointer")
        task = self.task.task()
        cell = self.cell
        try:
            kinematics, tools = cell.nominal_kinematics, cell_tools(cell)
            # where the arm stands: an encoder reading a hair past a limit the arm was sent to
            # is at that limit
            here = np.clip(self.snapshot.q, kinematics.lower, kinematics.upper)
            plan = plan_execution(task, kinematics, tools, here, cell.robot.joint_speed)
        except (RapidError, ExecutionError) as exc:
            message = str(exc).replace(f"{self.task.folder}/", "T_ROB1/")  # the client's names
            self.elog.add("plan_refused", message)
            raise ControllerError(400, "rapid", message) from None
        with self._lock:
            self._execution = Execution(plan)
        self.elog.add("pp_reset", f"to main of {plan.module} ({len(plan.moves)} moves)")

    def start(self) -> None:
        """Run the program from its pointer on the worker."""
        self.require_auto("start a program")
        with self._lock:
            if self.ctrlstate != "motoron":
                raise not_allowed("the motors are off: a program starts with the motors on")
            self._require_stopped("start")
            execution = self._execution
            if execution is None:
                raise not_allowed("the program pointer is not set (resetpp first)")
            if execution.next_move >= len(execution.plan.moves):
                raise not_allowed("the program pointer is at the end of main (resetpp first)")
            self.execstate = "running"
            self._halt.clear()
        self._changed("execution", "running")
        self.elog.add(
            "started", f"{execution.plan.module} from move {max(execution.next_move, 0) + 1}"
        )
        self.submit(lambda: self._run(execution))

    def stop(self) -> None:
        """Halt the program where the arm is (the pointer stays at the move it halted)."""
        if self.execstate == "running":
            self._halt.set()

    def _run(self, execution: Execution) -> None:
        """Run the program from its pointer (on the worker)."""
        cell, plan = self.cell, execution.plan
        self.pacer.relock(self.cell.time_s)
        ended = False
        message = ""
        try:
            cell.set_absolute_accuracy(None)
            if execution.next_move < 0:
                execution.start_time_s = cell.time_s
                self._changing_tool = True
                try:
                    start_plan(cell, plan, from_here=True)
                finally:
                    self._changing_tool = False
                execution.next_move = 0
                if self._halt.is_set():  # a stop asked during the tool change: halt here
                    raise MotionHaltedError("stop requested by a client during the tool change")
            while execution.next_move < len(plan.moves):
                move = plan.moves[execution.next_move]
                self._q_ref = move.q
                executed = run_move(cell, plan, move)
                if move.touch:
                    self._on_touch(move.target, plan.tool)
                execution.done.append(executed)
                execution.next_move += 1
            ended = True
            message = f"{plan.module}: the end of main after {len(plan.moves)} moves"
        except MotionHaltedError as exc:
            message = f"{plan.module}: halted at move {execution.next_move + 1} ({exc})"
        except SupervisionError as exc:
            self.elog.add("collision" if exc.code == "collision" else "supervision", str(exc))
            message = f"{plan.module}: stopped by the supervision ({exc.code})"
        except (ExecutionError, CellError) as exc:
            self.elog.add("execution_error", str(exc))
            message = f"{plan.module}: stopped: {exc}"
        finally:
            self._halt.clear()
            self._q_ref = self.cell.read_joints()
            self._refresh()
            with self._lock:
                self.execstate = "stopped"
        self.elog.add("stopped", message)
        self._say(message)
        self._changed("execution", "stopped")
        if ended:
            record = ExecutionRecord(
                plan, tuple(execution.done), execution.start_time_s, cell.time_s
            )
            self._on_end(record)

    # -- I/O ----------------------------------------------------------------------------------
    def signal(self, spec: SignalSpec) -> float:
        """A signal's value now (scenarios.twin.cell_io)."""
        return self.io.read(spec, self.snapshot)

    def set_signal(self, spec: SignalSpec, text: str) -> None:
        """Set an output; one that drives a device is refused while the program runs."""
        self.require_auto("set a signal")
        value = parse_value(spec, text)
        if spec.name in DEVICE_OUTPUTS:
            self._require_stopped(f"drive {spec.name}")
        self.io.write(spec, value)

    # -- EGM ----------------------------------------------------------------------------------
    def _egm_tick(self) -> None:
        """One control period of streamed guidance (on the worker), while no program runs."""
        if self.guidance is not None and self.execstate != "running":
            self._q_ref = self.guidance.tick(self._q_ref, self.ctrlstate == "motoron")
