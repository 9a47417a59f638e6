"""``recent run``: the main job — ground a task's Panda skills onto a robot and execute them."""

from __future__ import annotations

import json
import sys

from lerobot_policy_recent.recent_plugin.episode import run_episode
from lerobot_policy_recent.scripts.common import add_settings_arguments, agent_from_args, at_least
from lerobot_policy_recent.scripts.ground_cmd import grounding_summary, print_grounding
from lerobot_policy_recent.scripts.logs_cmd import add_log_arguments, recorder_from_args


def register(sub) -> None:
    parser = sub.add_parser("run", help="ground a task's skills for a robot and run one simulated episode")
    parser.add_argument(
        "--task",
        default="cube_in_bin",
        help="task id, e.g. kinematic/tidy_bench (`recent envs list`; default: cube_in_bin)",
    )
    parser.add_argument("--robot", default="UR5e", help="target embodiment (default: UR5e)")
    parser.add_argument("--seed", type=at_least(0), default=0, help="episode seed, >= 0 (default: 0)")
    parser.add_argument("--max_steps", type=at_least(1), default=None, help="step limit, >= 1 (default: the task's)")
    parser.add_argument(
        "--variations", default="off", help="off, on (pose perturbation, sensing noise, obstacle), all, or a comma list"
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of text")
    add_settings_arguments(parser)
    add_log_arguments(parser)
    parser.set_defaults(handler=_run)


def _run(args) -> int:
    agent = agent_from_args(args)
    recorder = recorder_from_args(args)
    try:
        result = run_episode(
            agent,
            args.task,
            args.robot,
            seed=args.seed,
            max_steps=args.max_steps,
            progress=not args.json,
            variations=args.variations,
            recorder=recorder,
            camera=args.camera,
        )
    except Exception:
        if recorder is not None:  # the error itself is printed by the CLI; say where its record is
            root = recorder.layout.root
            print(
                f"the episode's logs, with the error as its result: {root} (check: recent logs verify {root})",
                file=sys.stderr,
            )
        raise
    finally:
        if recorder is not None:
            recorder.close()
    summaries = [grounding_summary(g) for g in result.grounding.skills]
    record = {
        **result.to_record(),
        "adaptations": [
            {
                "kind": a.kind,
                "skill": a.skill,
                "segment": a.segment,
                "checks": list(a.checks),
                "observation": a.observation,
                "before": a.before,
                "after": a.after,
            }
            for a in result.adaptations
        ],
        "failures": [
            {"skill": f.skill, "line": f.line, "category": str(f.category), "message": f.message}
            for f in result.failures
        ],
        "skills": summaries,
        "log": _log_record(recorder),
    }
    if args.json:
        print(json.dumps(record, indent=2))
        return 0 if result.success else 1
    for summary in summaries:
        print_grounding(summary)
    for a in result.adaptations:
        verdict = "patched" if a.after else "the skill ends here, done" if a.kind == "achieved" else "no valid patch"
        print(f"  {a.kind} in {a.skill} segment {a.segment} ({', '.join(a.checks)}): {a.observation} -> {verdict}")
        if a.after:
            print("    " + a.after.replace("\n", "\n    "))
    for f in result.failures:
        print(f"  failure in {f.skill} line {f.line}: [{f.category}] {f.message}")
    outcome = "SUCCESS" if result.success else "FAILURE"
    print(
        f"{outcome}: {result.task_id} on {result.robot} (seed {result.seed}), {result.gc:.0%} of subtasks, "
        f"{result.steps} steps, {result.wall_seconds:.1f} s; "
        f"{result.generated_tokens} tokens generated vs {result.skill_tokens} skill tokens "
        f"(GO {result.go:.1f}% in repair/revise, {result.go_pre:.1f}% before execution), LM {result.lm_seconds:.2f} s, "
        f"first executable code after {result.grounding.igt_seconds:.2f} s; "
        f"{result.ei} interruptions ({result.it:.2f} s idle)"
        + (f", {result.patches - result.ei} more patches rendered without the LM" if result.patches > result.ei else "")
    )
    log = _log_record(recorder)
    if log:
        print(f"logged episode {log['episode']} to {log['dir']} (watch it: recent replay {log['replay']})")
        for sink, error in log["failed_sinks"].items():
            print(f"  log sink {sink} failed and was switched off: {error}")
    return 0 if result.success else 1


def _log_record(recorder) -> dict | None:
    if recorder is None:
        return None
    return {
        "dir": str(recorder.layout.root),
        "episode": recorder.last_episode,
        "replay": str(recorder.layout.rrd(recorder.last_episode))
        if recorder.last_episode is not None and recorder.layout.rrd(recorder.last_episode).exists()
        else f"{recorder.layout.root} --episode {recorder.last_episode}",
        "failed_sinks": dict(recorder.failed),
    }
