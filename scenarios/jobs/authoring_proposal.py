"""A change to propose where touches authored on the virtual cell do not pass it
(scenarios.jobs.program_authoring): the touches in another order (the joint moves between
them then take other ways), the table at another position, or the part turned on the table
(in the order given, then in another); the first that passes the virtual cell, said as what
to change.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from itertools import permutations
from typing import Any

from scenarios.configuration.config_files import with_overrides
from scenarios.configuration.job_config import JobConfig
from scenarios.offline.program_proposal import TURNS_DEG
from scenarios.offline.reach_proposal import turned_yaw_deg
from scenarios.offline.table_candidates import TABLE_CANDIDATES_M

#: Orders are tried for at most this many touches (their permutations).
MAX_ORDERED = 4
YAW_KEY = "cell.object.placement.yaw_deg"

#: Whether the touches pass the virtual cell of a job, the table at a position [m].
Attempt = Callable[[JobConfig, float, Sequence[Any]], bool]


def _order(touches: Sequence[Any]) -> str:
    return "the touches in the order " + ", ".join(t.name for t in touches)


def checked_change(
    config: JobConfig,
    table_position_m: float,
    touches: Sequence[Any],
    attempt: Attempt,
    say: Callable[[str], None] = lambda _msg: None,
) -> str | None:
    """The first change (see the module's docstring) with which `attempt` passes, as what
    to change, or None where none does; `say` tells what is tried (a search of every turn
    attempts the touches up to some 80 times, a second or two each)."""
    given = tuple(touches)
    orders = [p for p in permutations(given) if p != given] if len(given) <= MAX_ORDERED else []
    say(f"trying {len(orders)} other orders of the touches, then the table's positions")
    for order in orders:
        if attempt(config, table_position_m, order):
            return _order(order)
    for s in TABLE_CANDIDATES_M:
        if s != table_position_m and attempt(config, s, given):
            return f"--table {s * 1e3:g}"
    placement = config.cell.object.placement
    for turn in TURNS_DEG:
        yaw = turned_yaw_deg(placement.yaw_deg, turn)
        say(f"trying the part turned {turn:+g} deg on the table ({YAW_KEY}={yaw:g})")
        turned = with_overrides(config, {YAW_KEY: yaw}, "a proposed turn")
        assert isinstance(turned, JobConfig)
        for order in (given, *orders):
            if attempt(turned, table_position_m, order):
                also = "" if order == given else f", {_order(order)}"
                return f"--set {YAW_KEY}={yaw:g} (the part turned {turn:+g} deg on the table){also}"
    return None
