"""The campaigns the verify tests run: a small healthy one and the known-bad one."""

#: A one-line campaign at 20 Hz (few steps, fast), three shards of two cases.
SMALL = {
    "robot": "seven_dof",
    "rate": 20.0,
    "shard_size": 2,
    "families": [{"name": "box", "cases": 5, "steps": 12, "mode": "joint"}],
}
#: The known-bad configuration: the filter without its control period at 20 Hz, joint commands
#: of up to 2 rad/s (one period moves a joint 0.1 rad, more than the workspace buffer of 3 cm
#: at the tool), as the soak's "20 Hz, no dt" case of docs/reliability.md.
BAD = {
    "robot": "seven_dof",
    "rate": 20.0,
    "filter": {"dt": None, "max_speed": 2.0},
    "shard_size": 4,
    "shrink": 1,
    "families": [
        {"name": "push", "cases": 4, "steps": 40, "operator": "push", "mode": "joint",
         "obstacles": {"count": [0, 2]}, "lag": [0.0, 0.05], "noise": [0.0, 1e-4]}
    ],
}  # fmt: skip
#: A healthy campaign on the MuJoCo plant: 1 kHz, the filter given its period and an
#: acceleration bound the arm's torques can follow, the arm starting at rest; the margins carry
#: the servo's tracking error, so the tolerances are physical (0.1 mm, 0.1 mrad).
MUJOCO_GOOD = {
    "robot": "seven_dof",
    "rate": 1000.0,
    "shard_size": 3,
    "filter": {"max_speed": 1.0, "max_acceleration": 5.0},
    "properties": {"containment": {"tolerance": 1e-4}, "joint_limits": {"tolerance": 1e-4}},
    "families": [{"name": "physics", "cases": 5, "steps": 200, "mode": "joint", "plant": "mujoco"}],
}
#: The known-bad campaign on the MuJoCo plant.
MUJOCO_BAD = {**BAD, "families": [{**BAD["families"][0], "plant": "mujoco"}]}
