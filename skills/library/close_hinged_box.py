def close_hinged_box(env, task, box="box"):
    """Push the open lid from behind, past upright, so it falls shut."""
    base = task.get_object_position(box)
    hinge = [base[0] + 0.07, base[1], base[2] + 0.08]
    start = [hinge[0] + 0.09, hinge[1], hinge[2] + 0.08]
    goal = [hinge[0] - 0.08, hinge[1], hinge[2] + 0.08]
    push(env, task, start_pos=start, target_pos=goal, approach_axis="z")
