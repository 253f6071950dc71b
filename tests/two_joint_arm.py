"""A small test arm as URDF text: a base, an upper link (a cylinder of ``length`` [m]) on a
vertical revolute joint j1, and a tool link on a revolute joint j2 at the upper link's top.
The tests that fit spheres to it (the cache, the command line) give the tool's geometry and
any links and joints beyond it."""
from __future__ import annotations


def two_joint_arm_urdf(name: str, tool_geometry: str, length: float = 0.3, links: str = "",
                       joints: str = "") -> str:
    """The URDF text of the arm ``name`` whose tool link's collision geometry is
    ``tool_geometry`` (a URDF ``<geometry>`` body), with the ``links`` and ``joints`` beyond the tool
    (URDF text) after the arm's own."""
    return f"""<robot name="{name}">
  <link name="base"/>
  <link name="upper"><collision><origin xyz="0 0 {length / 2}"/><geometry><cylinder radius="0.04" length="{length}"/>
    </geometry></collision></link>
  <link name="tool"><collision><geometry>{tool_geometry}</geometry></collision></link>
{links}  <joint name="j1" type="revolute"><parent link="base"/><child link="upper"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="upper"/><child link="tool"/><origin xyz="0 0 {length}"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
{joints}</robot>
"""
