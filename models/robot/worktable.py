"""The sliding worktable: a carriage on a rail along the world y axis (1 m of travel).

The table frame is the `table_top` site: on the top surface, at the carriage's centre, axes
parallel to the world's. At table position s [m] it sits at `TABLE_TOP_POS + s * y`.
Objects fixed on the table are children of the `table` body.
"""

from __future__ import annotations

#: World position [m] of the table frame at table position 0.
TABLE_TOP_POS = (1.15, 0.0, 0.4)
#: Travel of the slide [m] and its speed limit [m/s].
TABLE_TRAVEL = (-0.5, 0.5)
TABLE_SPEED = 0.25
#: Half sizes [m] of the table top.
TABLE_HALF = (0.4, 0.3, 0.02)


def table_worldbody_xml() -> str:
    """The rail (static) and the carriage with its top, slide joint and `table_top` site."""
    x, y, z = TABLE_TOP_POS
    hx, hy, hz = TABLE_HALF
    lo, hi = TABLE_TRAVEL
    return f"""    <body name="table_rail" pos="{x} {y} 0">
      <geom type="box" size="0.15 0.9 {(z - 0.1) / 2:.6g}" pos="0 0 {(z - 0.1) / 2:.6g}"
            rgba="0.25 0.25 0.28 1"/>
    </body>
    <body name="table" pos="{x} {y} 0" gravcomp="1">
      <joint name="table_slide" type="slide" axis="0 1 0" range="{lo} {hi}" damping="50"/>
      <joint name="table_x" type="slide" axis="1 0 0" range="-0.01 0.01" armature="10"/>
      <joint name="table_z" type="slide" axis="0 0 1" range="-0.01 0.01" armature="10"/>
      <joint name="table_pitch" type="hinge" axis="1 0 0" pos="0 0 {z}" range="-0.01 0.01"
             armature="10"/>
      <joint name="table_yaw" type="hinge" axis="0 0 1" pos="0 0 {z}" range="-0.01 0.01"
             armature="10"/>
      <geom type="box" size="0.2 0.25 0.04" pos="0 0 {z - 0.09:.6g}" mass="30"
            rgba="0.3 0.3 0.33 1"/>
      <geom name="table_top" type="box" size="{hx} {hy} {hz}" pos="0 0 {z - hz:.6g}" mass="30"
            rgba="0.75 0.72 0.65 1"/>
      <site name="table_top" pos="0 0 {z}" size="0.01"/>
    </body>"""


#: The carriage's guideway errors (straightness, pitch, yaw) are joints held by stiff servos
#: at the values the real axis has at its position (cell.sim.devices.TableAxis).
TABLE_GUIDE_JOINTS: tuple[str, ...] = ("table_x", "table_z", "table_pitch", "table_yaw")


def table_actuator_xml() -> str:
    """The table's position servo [m] and the servos of its guideway errors (held at 0 in
    the nominal cell)."""
    lo, hi = TABLE_TRAVEL
    guide = "\n".join(
        f'    <general name="{name}" joint="{name}" ctrlrange="-0.01 0.01" gainprm="2e6" '
        'biastype="affine" biasprm="0 -2e6 -2e4"/>'
        for name in TABLE_GUIDE_JOINTS
    )
    return (
        f'    <general name="table_slide" joint="table_slide" ctrlrange="{lo - 0.05} {hi + 0.05}"\n'
        '             forcerange="-3000 3000" gainprm="2e5" biastype="affine"\n'
        '             biasprm="0 -2e5 -8e3"/>\n' + guide
    )
