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
from scenarios.rapid.reader import read_module
from scenarios.rapid.syntax import RapidError
from scenarios.rapid.task import RapidTask, read_task
from scenarios.twin.controller_errors import ControllerError, bad_request, not_allowed, not_found
from scenarios.twin.egm import EgmServer
from scenarios.twin.elog import EventLog
from scenarios.twin.file_service import FileService
from scenarios.twin.pacing import WallClockPacer
from scenarios.twin.signals import SIGNALS, SignalSpec, parse_value
from scenarios.twin.snapshot import Snapshot
from scenarios.twin.symbols import Symbol, find, set_value

#: The controller's control period: snapshots, EGM messages [s].
PERIOD_S = 0.004
#: A streamed reference older than this is not followed (the arm holds) [s].
STALE_S = 0.1
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
        self.task_folder = folder / "task"
        self.task_folder.mkdir(parents=True, exist_ok=True)
        self.elog = EventLog()
        self.ctrlstate = "motoron"
        self.opmode = opmode
        self.execstate = "stopped"
        self.cycle = "once"
        self.speedratio = 100
        self.signals: dict[str, float] = {s.name: 0.0 for s in SIGNALS}
        #: Hear every state change: (resource, value), e.g. ("execution", "running").
        self.listeners: list[Listener] = []
        self._on_touch = on_touch or (lambda _t, _tool: None)
        self._on_end = on_end or (lambda _r: None)
        self._say = say or (lambda _m: None)
        self._lock = threading.RLock()
        self._modules: dict[str, Path] = {}
        self._execution: Execution | None = None
        self._commands: queue.Queue[Callable[[], None]] = queue.Queue()
        self._halt = threading.Event()
        self._closing = threading.Event()
        self.pacer = WallClockPacer(speed, controller.time_s, self._lagging)
        self.egm: EgmServer | None = None
        q = controller.read_joints()
        self._q_ref = q
        self.snapshot = self._snapshot(q, q)
        controller.pace(self._clock)
        self.elog.add("motors_on", "the controller started with its motors on")
        self._worker = threading.Thread(target=self._work, name="twin-motion", daemon=True)
        self._worker.start()

    # -- the worker --------------------------------------------------------------------------
    def _work(self) -> None:
        streamed = False
        while not self._closing.is_set():
            streaming = self.egm is not None and self.egm.active()
            command: Callable[[], None]
            try:
                if streaming:
                    command = self._commands.get_nowait()
                else:
                    command = self._commands.get(timeout=0.05)
                streamed = False
            except queue.Empty:
                if not streaming:
                    continue
                if not streamed:
                    self.pacer.relock(self.cell.time_s)
                streamed = True
                command = self._egm_tick
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
        if self.egm is not None:
            self.egm.feedback(
                self.snapshot, self.ctrlstate == "motoron", self.execstate == "running"
            )
        self.pacer.keep_pace(time_s)
        if self._halt.is_set():
            return "stop requested by a client"
        return None

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
        )

    def _refresh(self) -> None:
        """A snapshot after a command that did not move (on the worker)."""
        self.snapshot = self._snapshot(self.cell.read_joints(), self._q_ref)
        self.signals["diToolLocked"] = float(self.cell.tool_in_hand is not None)
        tools = self.cell.tools
        held = self.cell.tool_in_hand
        self.signals["aiToolNumber"] = float(tools.index(held) + 1) if held in tools else 0.0
        self.signals["aiTablePosition"] = self.cell.table_position() * 1e3

    # -- state --------------------------------------------------------------------------------
    def _changed(self, resource: str, value: str) -> None:
        for listener in list(self.listeners):
            listener(resource, value)

    def set_ctrlstate(self, state: str) -> None:
        """Motors on or off (`motoron`, `motoroff`); motors off halts a running program."""
        self._require_auto("switch the motors")
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
        with self._lock:
            paths = list(self._modules.values())
        return [read_module(p) for p in paths]

    def module_names(self) -> list[str]:
        with self._lock:
            return [p.stem for p in self._modules.values()]

    def load_module(self, path: str, replace: bool = False) -> str:
        """Load the module file `path` (a file-service path) into T_ROB1; refused, with an
        event-log entry and nothing moved, if it does not read."""
        self._require_auto("load a module")
        data = self.files.read(path)
        self._require_stopped("load a module")
        try:
            module = read_module(data.decode("utf-8", errors="strict"), path)
        except (RapidError, UnicodeDecodeError) as exc:
            self.elog.add("load_refused", f"{path}: {exc}")
            raise ControllerError(
                400, "rapid", f"{path}: the module does not load: {exc}"
            ) from None
        key = module.name.casefold()
        with self._lock:
            if key in self._modules and not replace:
                raise not_allowed(
                    f"module {module.name} is loaded already (replace=true to load it again)"
                )
            target = self.task_folder / f"{module.name}.mod"
            target.write_bytes(data)
            self._modules[key] = target
            self._execution = None
        self.elog.add("loaded", f"{module.name} from {path}")
        return module.name

    def unload_module(self, name: str) -> None:
        self._require_auto("unload a module")
        self._require_stopped("unload a module")
        with self._lock:
            path = self._modules.pop(name.casefold(), None)
            if path is None:
                loaded = ", ".join(self.module_names()) or "none"
                raise not_found(f"module {name!r} is not loaded (loaded: {loaded})")
            path.unlink()
            self._execution = None
        self.elog.add("unloaded", name)

    def _task(self) -> RapidTask:
        with self._lock:
            paths = list(self._modules.values())
        if not paths:
            raise not_allowed("no module is loaded in T_ROB1")
        return read_task(paths)

    def symbol(self, path: str) -> Symbol:
        return find(self.modules(), path)

    def set_symbol(self, path: str, value: str) -> None:
        """Write a RAPID datum (the loaded module's text changes; the program reads it at the
        next program pointer reset)."""
        self._require_auto("write RAPID data")
        with self._lock:
            symbol = self.symbol(path)
            text = set_value(symbol, value)
            self._modules[symbol.module.name.casefold()].write_text(text, encoding="utf-8")
        self._changed(f"rapid:{symbol.url}", symbol.value)

    # -- execution ------------------------------------------------------------------------------
    def _require_auto(self, what: str) -> None:
        if self.opmode != "AUTO":
            raise not_allowed(
                f"cannot {what} in manual mode ({self.opmode}): a remote client does so in "
                "automatic mode (an IRC5 in manual mode takes it from the FlexPendant)"
            )

    def _require_stopped(self, what: str) -> None:
        if self.execstate == "running":
            raise not_allowed(f"cannot {what} while the program runs (stop it first)")

    def resetpp(self) -> None:
        """Plan the loaded task from main on the nominal arm (the data as they are now); a
        program that cannot run is refused here, with an event-log entry."""
        self._require_auto("reset the program pointer")
        self._require_stopped("reset the program pointer")
        task = self._task()
        cell = self.cell
        try:
            plan = plan_execution(
                task, cell.nominal_kinematics, cell_tools(cell), cell.q_home, cell.robot.joint_speed
            )
        except (RapidError, ExecutionError) as exc:
            message = str(exc).replace(f"{self.task_folder}/", "T_ROB1/")  # the client's names
            self.elog.add("plan_refused", message)
            raise ControllerError(400, "rapid", message) from None
        with self._lock:
            self._execution = Execution(plan)
        self.elog.add("pp_reset", f"to main of {plan.module} ({len(plan.moves)} moves)")

    def start(self) -> None:
        """Run the program from its pointer on the worker."""
        self._require_auto("start a program")
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
                start_plan(cell, plan)
                execution.next_move = 0
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
        name = spec.name
        if name.startswith("diUser"):
            return self.signals["doUser" + name[6:]]
        return self.signals[name]

    def set_signal(self, spec: SignalSpec, text: str) -> None:
        self._require_auto("set a signal")
        value = parse_value(spec, text)
        if spec.name == "aoGripperOpening":
            if self.cell.tool_in_hand != "gripper":
                raise not_allowed("aoGripperOpening: the gripper is not in hand")
            self._require_stopped("drive the gripper")
            self.submit(lambda: self._gripper(value))
        self.signals[spec.name] = value
        self._changed(f"signal:{spec.name}", str(value))

    def _gripper(self, opening_mm: float) -> None:
        self.pacer.relock(self.cell.time_s)
        self.cell.set_gripper(opening_mm * 1e-3)
        self._refresh()

    # -- EGM --------------------------------------------------------------------------------
    def _solve_flange(self, T_base_flange: np.ndarray) -> np.ndarray:
        """The joints (6,) [rad] that put the flange at `T_base_flange` on the nominal arm,
        from the joints commanded now."""
        return self.cell.nominal_kinematics.solve(T_base_flange, self.snapshot.q_ref, np.eye(4))

    def _egm_tick(self) -> None:
        """One control period of streamed guidance (on the worker): follow the reference if
        one is fresh, the motors on and no program running; else hold."""
        link = self.egm
        if link is None:
            return
        if self.execstate == "running":
            return
        reference = link.reference(self._solve_flange, STALE_S)
        if reference is not None and self.ctrlstate == "motoron":
            self._q_ref = reference
        try:
            self.cell.servo(self._q_ref, PERIOD_S)
        except SupervisionError as exc:
            self.elog.add("collision", f"EGM: {exc}")
            self._q_ref = self.cell.read_joints()
            link.refuse_until_new()
        except CellError as exc:
            link.refuse_until_new()
            self.elog.add("egm", f"EGM reference refused: {exc}")
            self._q_ref = self.snapshot.q_ref
