"""The failure taxonomy of the RECENT paper (appendix "Failure Categorization")."""

from __future__ import annotations

from enum import StrEnum


class FailureCategory(StrEnum):
    HALLUCINATED_NAME = "hallucinated_name"  # NameError: undefined variable or object
    HALLUCINATED_API = "hallucinated_api"  # AttributeError / a primitive the robot does not have
    HALLUCINATED_KWARG = "hallucinated_kwarg"  # TypeError: unexpected or missing keyword argument
    NON_EXECUTABLE = "non_executable"  # SyntaxError, forbidden construct
    EMPTY_CONTINUATION = "empty_continuation"  # the LM returned nothing usable
    MOTION_PLANNING = "motion_planning"  # waypoint blocked, misaligned gripper, IK failure
    WORKSPACE = "workspace"  # target outside the robot's workspace
    UNREACHABLE_OBJECT = "unreachable_object"  # object not reachable / not found
    GRASP_LOST = "grasp_lost"
    TIMEOUT = "timeout"
    BUDGET_EXCEEDED = "budget_exceeded"  # skill code stopped by the executor: too long without an action, or too big
    CANNOT_TRACK = "cannot_track"  # calibration, not grounding: the arm stopped short of a goal it was sent to
    EFFECT_UNMET = "effect_unmet"  # a step's declared effect was sensed missing, and doing it again did not help
    SUBTASK_FAILED = "subtask_failed"  # ran to the end, success predicate false
    UNSUPPORTED = "unsupported"  # the robot lacks a capability the skill needs: refused by the ontology, nothing run
    CRASH = "crash"  # not the method's failure: the run broke off (the LM worker died, an error); no verdict


REFUSED = "refused: "  # how a skill a check found infeasible before the arm moved ends (SkillExecutor.refuse)


def is_refusal(category: object, message: object) -> bool:
    """A skill refused by name as infeasible, not a failure of the attempt: as sensed (beyond reach,
    off the table), or as known before grounding (the robot has no primitive for one of its calls)."""
    if str(category) == FailureCategory.UNSUPPORTED:
        return True
    return str(category) == FailureCategory.UNREACHABLE_OBJECT and str(message or "").startswith(REFUSED)


PRIMITIVE_FAILURE_CATEGORY = {
    "unreachable": FailureCategory.UNREACHABLE_OBJECT,
    "out_of_workspace": FailureCategory.WORKSPACE,
    "waypoint_blocked": FailureCategory.MOTION_PLANNING,
    "misaligned": FailureCategory.MOTION_PLANNING,
    "timeout": FailureCategory.TIMEOUT,
    "object_not_found": FailureCategory.HALLUCINATED_NAME,
    "grasp_lost": FailureCategory.GRASP_LOST,
    "cannot_track": FailureCategory.CANNOT_TRACK,
}
