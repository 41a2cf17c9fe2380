"""Robot execution: the UR5e and its gripper, placement of the plan in the world, IK,
time parameterisation and export for a controller."""

__all__: list[str] = []  # nothing public: a plan is executed and exported through workflows.ScenePlan
