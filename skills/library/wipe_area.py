def wipe_area(env, task, area="stain"):
    """Wipe the marked area in four strokes with the closed fingertips just above the table."""
    area_pos = task.get_object_position(area)
    for dy in [-0.045, -0.015, 0.015, 0.045]:
        push(
            env,
            task,
            start_pos=[area_pos[0] - 0.09, area_pos[1] + dy, area_pos[2] + 0.012],
            target_pos=[area_pos[0] + 0.09, area_pos[1] + dy, area_pos[2] + 0.012],
            approach_axis="z",
        )
