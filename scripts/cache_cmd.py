"""``recent cache info|clear``: the on-disk store of grounded skills (models are kept apart, by `recent model`)."""

from __future__ import annotations

from lerobot_policy_recent.recent_plugin.grounding.store import ENV, GroundingStore, store_dir


def register(sub) -> None:
    parser = sub.add_parser(
        "cache",
        help="the grounded skills kept on disk across processes: where, how much; clear them",
        description="A grounded skill is stored once it validates, keyed by its code, the robot, the ontology, "
        "the model's sha256, the backend's settings, the method and the budgets, so a new process grounding "
        f"the same skill for the same robot reads it back. ${ENV} sets the directory, or 'off'.",
    )
    actions = parser.add_subparsers(dest="cache_command", metavar="{info,clear}", required=True)
    actions.add_parser("info", help="the store's directory, files and size").set_defaults(handler=_info)
    actions.add_parser("clear", help="remove every stored grounding (models are not touched)").set_defaults(
        handler=_clear
    )


def _store() -> GroundingStore | None:
    root = store_dir()
    if root is None:
        print(f"the grounding cache is off (${ENV}=off)")
    return GroundingStore(root) if root else None


def _info(args) -> int:
    store = _store()
    if store:
        print(
            f"{store.root}: {len(store.files())} grounded skills, {store.size() / 1e6:.2f} MB "
            f"(bound {store.max_bytes / 1e6:.0f} MB)"
        )
    return 0


def _clear(args) -> int:
    store = _store()
    if store:
        files, size = store.clear()
        print(f"removed {files} grounded skills ({size / 1e6:.2f} MB) from {store.root}")
    return 0
