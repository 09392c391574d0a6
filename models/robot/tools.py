"""The tools of the cell, their rack and the tool changer's geometry.

Every tool's body frame is its changer interface: when the tool is seated on the flange the
tool frame coincides with the flange frame (z out of the flange). Each tool has a TCP site
`<tool>_tcp`; its pose in the tool frame is `ToolSpec.p_tool_tcp` / `quat_tool_tcp` (wxyz).

Tool geoms are in geom group 4 (the laser and IR rays ignore that group). Tool bodies carry
gravcomp: the controller's payload model (an ABB controller's `tooldata` load), so that a tool
in hand does not load the arm's servos.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

TOOL_GROUP = 4


@dataclass(frozen=True)
class ToolSpec:
    """A tool's nominal data: name, TCP in the tool frame [m] (quaternion wxyz), mass [kg]."""

    name: str
    p_tool_tcp: tuple[float, float, float]
    quat_tool_tcp: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)
    mass: float = 1.0

    @property
    def body(self) -> str:
        """Name of the tool's body in the scene."""
        return f"tool_{self.name}"

    @property
    def tcp_site(self) -> str:
        """Name of the tool's TCP site in the scene."""
        return f"{self.name}_tcp"

    @property
    def T_tool_tcp(self) -> np.ndarray:
        """(4, 4) homogeneous transform of the TCP in the tool (= flange) frame."""
        w, x, y, z = self.quat_tool_tcp
        R = np.array(
            [
                [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
            ]
        )
        T = np.eye(4)
        T[:3, :3] = R
        T[:3, 3] = self.p_tool_tcp
        return T


GRIPPER = ToolSpec("gripper", (0.0, 0.0, 0.155), mass=1.2)
SCREWER = ToolSpec("screwer", (0.0, 0.0, 0.20), mass=1.5)
IR = ToolSpec("ir", (0.0, 0.0, 0.05), mass=0.3)
LASER = ToolSpec("laser", (0.0, 0.0, 0.10), mass=0.8)
TOOLS: tuple[ToolSpec, ...] = (GRIPPER, SCREWER, IR, LASER)

#: Gripper finger travel [m] per finger (0 = closed, fingers touching).
FINGER_TRAVEL = 0.05
#: Rack: world position of its frame, slot positions along x in the rack frame [m].
RACK_POS = (0.0, -0.85, 0.0)
SLOT_HEIGHT = 0.8
SLOT_X = (0.0, 0.25, 0.5, 0.75)
#: The TCP check station's light beam (a light barrier, as ABB's BullsEye): its centre
#: relative to the rack frame [m] (in front of the slots, towards the arm) and its half
#: length along x [m].
BEAM_OFFSET = (0.375, 0.35, 0.95)
BEAM_HALF_M = 0.05


def beam_line(
    rack_xyz: tuple[float, float, float] = RACK_POS,
) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """The TCP check beam's two ends [m] (emitter, receiver), for the rack at `rack_xyz`."""
    c = [r + o for r, o in zip(rack_xyz, BEAM_OFFSET, strict=True)]
    return (c[0] - BEAM_HALF_M, c[1], c[2]), (c[0] + BEAM_HALF_M, c[1], c[2])


#: Slot orientation (wxyz): the tool hangs with its z axis down (rotation of pi about x).
SLOT_QUAT = (0.0, 1.0, 0.0, 0.0)


def slot_pos(
    index: int, rack_xyz: tuple[float, float, float] = RACK_POS
) -> tuple[float, float, float]:
    """World position [m] of rack slot `index` (the seated tool frame's origin) for the rack
    standing at `rack_xyz` [m]."""
    return (rack_xyz[0] + SLOT_X[index], rack_xyz[1], rack_xyz[2] + SLOT_HEIGHT)


def _plate() -> str:
    return '<geom type="cylinder" size="0.032 0.008" pos="0 0 0.008" rgba="0.3 0.3 0.35 1"/>'


def _tool_body(
    spec: ToolSpec, index: int, content: str, rack_xyz: tuple[float, float, float]
) -> str:
    x, y, z = slot_pos(index, rack_xyz)
    qw, qx, qy, qz = SLOT_QUAT
    tcp = " ".join(f"{v:.12g}" for v in spec.p_tool_tcp)
    tq = " ".join(f"{v:.12g}" for v in spec.quat_tool_tcp)
    return f"""    <body name="{spec.body}" pos="{x:.12g} {y:.12g} {z:.12g}"
          quat="{qw} {qx} {qy} {qz}" childclass="tool" gravcomp="1">
      <freejoint name="{spec.body}_free"/>
      {_plate()}
{content}
      <site name="{spec.tcp_site}" pos="{tcp}" quat="{tq}" size="0.006" rgba="1 0 0 1"/>
    </body>"""


def tools_worldbody_xml(rack_xyz: tuple[float, float, float] = RACK_POS) -> str:
    """The tool bodies, each seated in its rack slot (free joints held by rack welds)."""
    gripper = f"""      <geom type="box" size="0.05 0.03 0.035" pos="0 0 0.05" mass="0.9"/>
      <body name="finger_left" pos="0.009 0 0" gravcomp="1">
        <joint name="finger_left" type="slide" axis="1 0 0" range="0 {FINGER_TRAVEL}"
               damping="2"/>
        <geom class="finger" type="box" size="0.008 0.015 0.04" pos="0 0 0.13"/>
      </body>
      <body name="finger_right" pos="-0.009 0 0" gravcomp="1">
        <joint name="finger_right" type="slide" axis="-1 0 0" range="0 {FINGER_TRAVEL}"
               damping="2"/>
        <geom class="finger" type="box" size="0.008 0.015 0.04" pos="0 0 0.13"/>
      </body>"""
    screwer = """      <geom type="cylinder" size="0.03 0.06" pos="0 0 0.076" mass="1.3"/>
      <body name="screwer_spindle" pos="0 0 0.136" gravcomp="1">
        <joint name="screwer_spindle" type="hinge" axis="0 0 1" armature="1e-4"/>
        <geom type="cylinder" size="0.012 0.02" pos="0 0 0.02" mass="0.1"/>
        <geom type="capsule" size="0.003" fromto="0 0 0.04 0 0 0.064" mass="0.01"/>
      </body>"""
    ir = """      <geom type="box" size="0.02 0.02 0.02" pos="0 0 0.03" mass="0.2"/>"""
    laser = """      <geom type="box" size="0.06 0.03 0.045" pos="0 0 0.055" mass="0.6"/>"""
    contents = {"gripper": gripper, "screwer": screwer, "ir": ir, "laser": laser}
    return "\n".join(
        _tool_body(spec, i, contents[spec.name], rack_xyz) for i, spec in enumerate(TOOLS)
    )


def rack_worldbody_xml(rack_xyz: tuple[float, float, float] = RACK_POS) -> str:
    """The static rack, its frame at `rack_xyz` [m] (the slots `SLOT_HEIGHT` above it): a
    beam on two posts standing on the floor, one slot site per tool, and the TCP check
    station's emitter and receiver on either end of its light beam (`beam_line`)."""
    x0, y0, z0 = rack_xyz
    length = SLOT_X[-1] - SLOT_X[0] + 0.3
    cx = x0 + (SLOT_X[0] + SLOT_X[-1]) / 2.0
    slots = "\n".join(
        f'      <site name="slot_{spec.name}" pos="{SLOT_X[i]:.12g} 0 {SLOT_HEIGHT}" '
        f'quat="{" ".join(str(v) for v in SLOT_QUAT)}" size="0.01"/>'
        for i, spec in enumerate(TOOLS)
    )
    beam = f'size="{length / 2:.6g} 0.03 0.02" pos="{cx - x0:.6g} -0.12 {SLOT_HEIGHT - 0.03}"'
    h = (z0 + SLOT_HEIGHT - 0.05) / 2
    post_l = f'size="0.03 0.03 {h:.6g}" pos="{cx - x0 - length / 2:.6g} -0.12 {h - z0:.6g}"'
    post_r = f'size="0.03 0.03 {h:.6g}" pos="{cx - x0 + length / 2:.6g} -0.12 {h - z0:.6g}"'
    (a, b) = beam_line(rack_xyz)
    station = "\n".join(  # the TCP check's emitter and receiver: seen, not in the way
        f'      <geom name="beam_{end}" type="box" size="0.008 0.012 0.015" '
        f'pos="{p[0] - x0 + side * 0.012:.6g} {p[1] - y0:.6g} {p[2] - z0:.6g}" group="2" '
        'contype="0" conaffinity="0" rgba="0.85 0.3 0.1 1"/>'
        for end, p, side in (("emitter", a, -1.0), ("receiver", b, 1.0))
    )
    return f"""    <body name="rack" pos="{x0} {y0} {z0}">
      <geom type="box" {beam} rgba="0.4 0.4 0.45 1"/>
      <geom type="box" {post_l} rgba="0.4 0.4 0.45 1"/>
      <geom type="box" {post_r} rgba="0.4 0.4 0.45 1"/>
{station}
{slots}
    </body>"""


def tools_equality_xml() -> str:
    """Two welds per tool: to its rack slot (active) and to the flange (inactive)."""
    lines = []
    for spec in TOOLS:
        lines.append(
            f'    <weld name="rack_{spec.name}" body1="{spec.body}" body2="rack" class="changer"/>'
        )
        lines.append(
            f'    <weld name="flange_{spec.name}" body1="{spec.body}" body2="link6" '
            'active="false" class="changer"/>'
        )
    return "\n".join(lines)


def tools_contact_xml() -> str:
    """Tools never collide with the rack or the wrist they are seated on."""
    lines = []
    for spec in TOOLS:
        for other in ("rack", "link6", "link5"):
            lines.append(f'    <exclude body1="{spec.body}" body2="{other}"/>')
    lines.extend(
        f'    <exclude body1="{finger}" body2="{other}"/>'
        for finger in ("finger_left", "finger_right")
        for other in ("rack", "link6", "link5")
    )
    lines.append('    <exclude body1="screwer_spindle" body2="rack"/>')
    return "\n".join(lines)


def tools_actuator_xml() -> str:
    """Finger servos (force-limited, [m]) and the screwer spindle (velocity [rad/s])."""
    return f"""    <position name="finger_left" joint="finger_left" kp="2000" kv="40"
              ctrlrange="0 {FINGER_TRAVEL}" forcerange="-40 40"/>
    <position name="finger_right" joint="finger_right" kp="2000" kv="40"
              ctrlrange="0 {FINGER_TRAVEL}" forcerange="-40 40"/>
    <velocity name="screwer_spindle" joint="screwer_spindle" kv="0.05" ctrlrange="-60 60"
              forcerange="-2 2"/>"""
