"""The cell: MuJoCo build, physics, controller API, sensors, tool changer, kinematics."""
