"""The IRB2000-class arm as a robot-only MJCF, generated from its kinematic parameters.

The numbers are those of an ABB IRB 2400 (the IRB 2000's successor): see README.md beside this
file. The same generator writes the nominal arm (what the programmer believes) and a perturbed
one (the real arm): link lengths and joint zero offsets are parameters.

Frames: the base frame is the robot's world frame (z up, x forward). At q = 0 the upper arm
points up and the forearm forward, the flange faces +x. The `flange` site has z out of the
flange (ABB's tool0).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

JOINT_NAMES: tuple[str, ...] = ("joint1", "joint2", "joint3", "joint4", "joint5", "joint6")
BODY_NAMES: tuple[str, ...] = ("base", "link1", "link2", "link3", "link4", "link5", "link6")
FLANGE_SITE = "flange"

_DEG = np.pi / 180.0
#: Joint limits [rad], IRB 2400 (axis 6 limited to +-400 deg).
JOINT_LOWER = np.array([-180.0, -100.0, -60.0, -200.0, -120.0, -400.0]) * _DEG
JOINT_UPPER = np.array([180.0, 110.0, 65.0, 200.0, 120.0, 400.0]) * _DEG
#: Joint speed limits [rad/s], IRB 2400.
JOINT_SPEED = np.array([150.0, 150.0, 150.0, 360.0, 360.0, 450.0]) * _DEG
#: `home` keyframe [rad]: wrist above the worktable, flange pointing down.
Q_HOME = np.array([0.0, 0.0, 0.0, 0.0, np.pi / 2, 0.0])

# Joint axes in the parent-aligned link frames.
_AXES = ((0, 0, 1), (0, 1, 0), (0, 1, 0), (1, 0, 0), (0, 1, 0), (1, 0, 0))
# Servo gains: stiffness [N m/rad], damping [N m s/rad], torque limit (JOINT_TORQUE) [N m],
# rotor inertia reflected through the gearbox [kg m^2]. Gravity is compensated (body
# gravcomp), so the gains only carry the dynamics.
_KP = (4.0e5, 4.0e5, 2.0e5, 2.0e4, 2.0e4, 1.0e4)
_KV = (8.0e3, 8.0e3, 4.0e3, 4.0e2, 4.0e2, 2.0e2)
JOINT_TORQUE = (4000.0, 4000.0, 2500.0, 600.0, 600.0, 300.0)
_ARMATURE = (8.0, 8.0, 4.0, 0.4, 0.4, 0.2)
# Masses [kg] of the links (base is fixed and massless for dynamics purposes).
_MASS = (0.0, 90.0, 28.0, 30.0, 10.0, 3.0, 0.6)


@dataclass(frozen=True)
class ArmGeometry:
    """Kinematic parameters of the arm [m, rad].

    `d1` base to shoulder height, `a1` shoulder forward offset, `a2` upper arm, `a3` elbow
    offset, `d4` forearm (elbow to wrist centre), `d6` wrist centre to flange.
    `joint_offsets` (6,) are zero offsets: the link turns by q + offset when the joint reads q.
    """

    d1: float = 0.615
    a1: float = 0.100
    a2: float = 0.705
    a3: float = 0.135
    d4: float = 0.755
    d6: float = 0.085
    joint_offsets: tuple[float, ...] = field(default=(0.0,) * 6)

    def __post_init__(self) -> None:
        lengths = (self.d1, self.a1, self.a2, self.a3, self.d4, self.d6)
        if not all(np.isfinite(v) and v > 0.0 for v in lengths):
            raise ValueError(f"arm lengths must be finite and positive, got {lengths}")
        if len(self.joint_offsets) != 6 or not np.all(np.isfinite(self.joint_offsets)):
            raise ValueError(f"joint_offsets must be 6 finite angles, got {self.joint_offsets}")

    def perturbed(
        self, d_lengths: np.ndarray | tuple[float, ...], d_offsets: np.ndarray | tuple[float, ...]
    ) -> ArmGeometry:
        """A copy with the six lengths and six joint offsets changed by the given amounts."""
        dl = np.asarray(d_lengths, dtype=float).reshape(6)
        do = np.asarray(d_offsets, dtype=float).reshape(6)
        return replace(
            self,
            d1=self.d1 + dl[0],
            a1=self.a1 + dl[1],
            a2=self.a2 + dl[2],
            a3=self.a3 + dl[3],
            d4=self.d4 + dl[4],
            d6=self.d6 + dl[5],
            joint_offsets=tuple(float(a + b) for a, b in zip(self.joint_offsets, do, strict=True)),
        )


def _f(values: Sequence[float] | np.ndarray) -> str:
    return " ".join(f"{float(v):.12g}" for v in values)


def _quat_axis_angle(axis: tuple[int, int, int], angle: float) -> str:
    s = np.sin(angle / 2.0)
    return _f((np.cos(angle / 2.0), axis[0] * s, axis[1] * s, axis[2] * s))


def _box_inertia(mass: float, size: tuple[float, float, float]) -> str:
    x, y, z = (2.0 * s for s in size)
    return _f(
        (
            mass * (y * y + z * z) / 12.0,
            mass * (x * x + z * z) / 12.0,
            mass * (x * x + y * y) / 12.0,
        )
    )


def servo_actuators(
    lower: Sequence[float] | np.ndarray,
    upper: Sequence[float] | np.ndarray,
    effort: Sequence[float] | np.ndarray,
    kp: Sequence[float] | np.ndarray,
    kv: Sequence[float] | np.ndarray,
) -> str:
    """The six joints' position servos as MJCF `<general>` actuators: gains `kp` [N m/rad]
    and `kv` [N m s/rad], torque within +-`effort` [N m], set-points within the joint range
    (`lower`, `upper` [rad]) widened by 0.2 rad."""
    return "\n".join(
        f'    <general name="{JOINT_NAMES[i]}" joint="{JOINT_NAMES[i]}" '
        f'ctrlrange="{lower[i] - 0.2:.12g} {upper[i] + 0.2:.12g}" '
        f'forcerange="{-effort[i]:g} {effort[i]:g}" gainprm="{kp[i]:g}" '
        f'biastype="affine" biasprm="0 {-kp[i]:g} {-kv[i]:g}"/>'
        for i in range(6)
    )


@dataclass(frozen=True)
class LinkXml:
    """One moving link of an arm's robot-only MJCF, as its text: the body's `name`, its
    placement attributes in the parent's frame (' pos="..."', with ' quat="..."' if it turns),
    its `inertial` and `joint` elements, and its `geoms` (collision and visual)."""

    name: str
    placement: str
    inertial: str
    joint: str
    geoms: tuple[str, ...]


def arm_document(
    name: str,
    links: Sequence[LinkXml],
    base: Sequence[str],
    flange_site: str,
    actuators: str,
    q_home: Sequence[float] | np.ndarray,
    rgba: str,
    on_floor: Sequence[str] = (),
) -> str:
    """The robot-only MJCF of a serial arm named `name`, as the cell expects it: a `base` body
    (its elements `base`) carrying `links` as a chain (joints `joint1`..`joint6`), the
    `flange_site` element in the last, the arm's own bodies excluded from touching each
    other, and those named in `on_floor` from touching the world's geometry (the floor),
    its servos (`actuators`, servo_actuators) and a `home` keyframe at `q_home` (6,)
    [rad]. Visual geoms in group 2 coloured `rgba`, collision geoms in group 3. The one
    writer of arm models: the built-in arm (arm_xml) and any arm from its file
    (cell.arm_mjcf) are both written here."""

    def chain(k: int, indent: str) -> str:
        link = links[k]
        lines = [
            f'{indent}<body name="{link.name}"{link.placement} gravcomp="1">',
            f"{indent}  {link.inertial}",
            f"{indent}  {link.joint}",
            *(f"{indent}  {geom}" for geom in link.geoms),
            f"{indent}  {flange_site}" if k == len(links) - 1 else chain(k + 1, indent + "  "),
            f"{indent}</body>",
        ]
        return "\n".join(lines)

    names = ("base", *(link.name for link in links))
    pairs = [(a, b) for i, a in enumerate(names) for b in names[i + 1 :]]
    pairs += [("world", b) for b in on_floor]
    excludes = "\n".join(f'    <exclude body1="{a}" body2="{b}"/>' for a, b in pairs)
    base_lines = "\n".join(f"      {line}" for line in base)
    return f"""<mujoco model="{name}">
  <compiler angle="radian" autolimits="true"/>

  <default>
    <default class="{name}">
      <default class="visual">
        <geom group="2" contype="0" conaffinity="0" rgba="{rgba}"/>
      </default>
      <default class="collision">
        <geom group="3" rgba="0.5 0.5 0.5 1"/>
      </default>
    </default>
  </default>

  <worldbody>
    <body name="base" childclass="{name}">
{base_lines}
{chain(0, "      ")}
    </body>
  </worldbody>

  <contact>
{excludes}
  </contact>

  <actuator>
{actuators}
  </actuator>

  <keyframe>
    <key name="home" qpos="{_f(q_home)}" ctrl="{_f(q_home)}"/>
  </keyframe>
</mujoco>
"""


_LinkShape = tuple[tuple[float, float, float], tuple[float, float, float], list[str]]


def _irb_links(
    g: ArmGeometry,
) -> tuple[tuple[tuple[float, float, float], ...], tuple[_LinkShape, ...]]:
    """The built-in arm's link positions in their parents' frames, and per link its
    inertial centre, the half sizes of the box its inertia is taken from, and its collision
    geoms (the visual ones are their copies), for the geometry `g`."""
    # Child body positions in the parent link frame.
    pos = (
        (0.0, 0.0, 0.0),
        (g.a1, 0.0, g.d1),
        (0.0, 0.0, g.a2),
        (0.0, 0.0, g.a3),
        (g.d4, 0.0, 0.0),
        (g.d6, 0.0, 0.0),
    )
    # Per link: inertial centre, box half sizes (inertia), and geoms (visual = collision shape).
    half_d4 = g.d4 / 2.0
    links = (
        # link1: turret
        (
            (0.05, 0.0, 0.35),
            (0.25, 0.25, 0.3),
            [
                f'<geom class="collision" type="cylinder" size="0.2 0.15" pos="0 0 {0.2:.6g}"/>',
                f'<geom class="collision" type="capsule" size="0.14" '
                f'fromto="0 0 0.35 {g.a1:.6g} 0 {g.d1:.6g}"/>',
            ],
        ),
        # link2: upper arm
        (
            (0.0, 0.0, g.a2 / 2.0),
            (0.1, 0.1, g.a2 / 2.0),
            [
                f'<geom class="collision" type="capsule" size="0.1" '
                f'fromto="0 -0.12 0 0 -0.12 {g.a2:.6g}"/>',
            ],
        ),
        # link3: elbow housing
        (
            (0.1, 0.0, g.a3),
            (0.15, 0.1, 0.1),
            [
                '<geom class="collision" type="capsule" size="0.1" '
                f'fromto="-0.15 0 {g.a3:.6g} 0.15 0 {g.a3:.6g}"/>',
            ],
        ),
        # link4: forearm
        (
            (half_d4, 0.0, 0.0),
            (half_d4, 0.07, 0.07),
            [
                f'<geom class="collision" type="capsule" size="0.07" '
                f'fromto="0.2 0 0 {g.d4 - 0.09:.6g} 0 0"/>',
            ],
        ),
        # link5: wrist
        (
            (0.0, 0.0, 0.0),
            (0.06, 0.06, 0.06),
            [
                '<geom class="collision" type="cylinder" size="0.06 0.06" '
                'quat="0.7071068 0.7071068 0 0"/>',
            ],
        ),
        # link6: flange
        (
            (-0.01, 0.0, 0.0),
            (0.015, 0.04, 0.04),
            [
                '<geom class="collision" type="cylinder" size="0.04 0.01" pos="-0.01 0 0" '
                'quat="0.7071068 0 0.7071068 0"/>',
            ],
        ),
    )

    return pos, links


def arm_xml(geometry: ArmGeometry | None = None, model_name: str = "irb2400") -> str:
    """The robot-only MJCF of the arm (no includes; the base is the first worldbody body)."""
    g = geometry or ArmGeometry()
    off = g.joint_offsets
    pos, links = _irb_links(g)

    def link(i: int) -> LinkXml:
        com, half, geoms = links[i]
        quat = f' quat="{_quat_axis_angle(_AXES[i], off[i])}"' if off[i] != 0.0 else ""
        both = []
        for geom in geoms:
            both += [geom, geom.replace('class="collision"', 'class="visual"')]
        return LinkXml(
            BODY_NAMES[i + 1],
            f' pos="{_f(pos[i])}"{quat}',
            f'<inertial pos="{_f(com)}" mass="{_MASS[i + 1]}" '
            f'diaginertia="{_box_inertia(_MASS[i + 1], half)}"/>',
            f'<joint name="{JOINT_NAMES[i]}" axis="{_f(_AXES[i])}" '
            f'range="{JOINT_LOWER[i]:.12g} {JOINT_UPPER[i]:.12g}" armature="{_ARMATURE[i]}"/>',
            tuple(both),
        )

    return arm_document(
        model_name,
        [link(i) for i in range(6)],
        (
            '<inertial pos="0 0 0.1" mass="50" diaginertia="1 1 1"/>',
            '<geom class="collision" type="cylinder" size="0.25 0.1" pos="0 0 0.1"/>',
            '<geom class="visual" type="cylinder" size="0.25 0.1" pos="0 0 0.1"/>',
        ),
        f'<site name="{FLANGE_SITE}" quat="0.70710678118654757 0 0.70710678118654757 0" '
        'size="0.01"/>',
        servo_actuators(JOINT_LOWER, JOINT_UPPER, JOINT_TORQUE, _KP, _KV),
        Q_HOME,
        "0.93 0.55 0.12 1",
    )
