"""The cell's scene MJCF: floor, light, the arm (included), sliding table, rack and tools."""

from __future__ import annotations

from models.robot.arm import JOINT_NAMES
from models.robot.tools import (
    RACK_POS,
    TOOL_GROUP,
    rack_worldbody_xml,
    tools_actuator_xml,
    tools_contact_xml,
    tools_equality_xml,
    tools_worldbody_xml,
)
from models.robot.worktable import table_actuator_xml, table_worldbody_xml

ROBOT_FILE = "irb2400.xml"
#: Physics time step [s].
TIMESTEP = 0.002


def scene_xml(robot_file: str = ROBOT_FILE, rack_xyz: tuple[float, float, float] = RACK_POS) -> str:
    """The scene MJCF; it includes the robot-only file `robot_file`; the tool rack stands at
    `rack_xyz` [m]."""
    sensors = "\n".join(
        f'    <jointpos name="{name}" joint="{name}"/>' for name in (*JOINT_NAMES, "table_slide")
    )
    return f"""<mujoco model="twincell">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="{TIMESTEP}" integrator="implicitfast" cone="elliptic" impratio="10"/>

  <include file="{robot_file}"/>

  <statistic center="0.6 0 0.7" extent="1.8"/>
  <visual>
    <headlight diffuse="0.6 0.6 0.6" ambient="0.3 0.3 0.3" specular="0 0 0"/>
    <global azimuth="150" elevation="-25"/>
  </visual>

  <default>
    <default class="tool">
      <geom group="{TOOL_GROUP}" rgba="0.2 0.45 0.7 1" friction="1 0.005 0.0001"/>
      <default class="finger">
        <geom rgba="0.15 0.15 0.15 1" friction="1.5 0.01 0.001" condim="4" mass="0.05"
              solref="0.004 1" solimp="0.95 0.99 0.0005"/>
      </default>
    </default>
    <default class="changer">
      <equality solref="0.004 1" solimp="0.9999 0.9999 0.001 0.5 2"/>
    </default>
  </default>

  <worldbody>
    <light pos="0.5 0 3" dir="0 0 -1" directional="true"/>
    <geom name="floor" type="plane" size="0 0 0.05" rgba="0.55 0.55 0.55 1"/>
{table_worldbody_xml()}
{rack_worldbody_xml(rack_xyz)}
{tools_worldbody_xml(rack_xyz)}
  </worldbody>

  <contact>
    <exclude body1="table" body2="table_rail"/>
{tools_contact_xml()}
  </contact>

  <equality>
{tools_equality_xml()}
  </equality>

  <actuator>
{table_actuator_xml()}
{tools_actuator_xml()}
  </actuator>

  <sensor>
{sensors}
  </sensor>
</mujoco>
"""
