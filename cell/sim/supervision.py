"""The controller's supervision of the cell, as an industrial controller has it.

- Motion supervision (ABB's Collision Detection option): the controller compares the motor
  torques with what its dynamic model expects; an external force on the arm or the tool
  beyond the threshold stops the move within milliseconds and backs the arm off along its
  path. Here the external force is the contacts' force on the arm's links and the tool in
  hand.
- The joint readings' plausibility: a joint's two encoder channels (a safety encoder's
  redundant ones) must agree; a reading where they do not is a glitch, read again.
- The static load check after a tool is locked: the motor torques holding the arm still
  against what the tool's tooldata (its payload model) needs.

Thresholds are the controller's configuration (its data sheet's defaults), never the
simulation's own figures.
"""

from __future__ import annotations

from collections.abc import Callable

import mujoco
import numpy as np

from cell.sim.simulation import Simulation


class ContactSensing:
    """The external force on the arm and the tool in hand (`held()`: its name, or None),
    from the contacts of the physics (the controller's estimate of it from the motor
    torques, without its noise)."""

    def __init__(self, sim: Simulation, held: Callable[[], str | None]) -> None:
        self.sim = sim
        m = sim.model
        arm = {int(m.body(f"link{i}").id) for i in range(1, 7)}
        self._arm = np.zeros(m.nbody, dtype=bool)
        self._arm[list(arm)] = True
        self._tool_bodies = {name: self._subtree(body) for name, body in sim.tool_body.items()}
        self._force = np.zeros(6)
        self.held = held

    def _subtree(self, root: int) -> np.ndarray:
        m = self.sim.model
        out = np.zeros(m.nbody, dtype=bool)
        for b in range(m.nbody):
            a = b
            while a > 0 and a != root:
                a = int(m.body_parentid[a])
            out[b] = a == root
        return out

    def _mask(self) -> np.ndarray:
        mask = self._arm.copy()
        tool = self.held()
        if tool is not None:
            mask |= self._tool_bodies[tool]
        return mask

    def external(self) -> tuple[float, str]:
        """The largest contact force [N] on the arm or the tool in hand now, and the body it
        acts on and what it meets: the other body, or its geom where that is named (an
        object's contact piece: "screwer_spindle against object_hull3"; "" if none)."""
        d, m = self.sim.data, self.sim.model
        n = d.ncon
        if n == 0:
            return 0.0, ""
        geoms = d.contact.geom[:n]
        bodies = m.geom_bodyid[geoms]
        mask = self._mask()
        ours = mask[bodies]
        hits = np.nonzero(ours[:, 0] ^ ours[:, 1])[0]  # ours against anything else
        best, where = 0.0, ""
        for i in hits:
            mujoco.mj_contactForce(m, d, int(i), self._force)
            f = float(np.linalg.norm(self._force[:3]))
            if f > best:
                k = 0 if ours[i, 0] else 1
                geom = m.geom(int(geoms[i, 1 - k]))
                met = geom.name or m.body(int(bodies[i, 1 - k])).name
                best, where = f, f"{m.body(int(bodies[i, k])).name} against {met}"
        return best, where
