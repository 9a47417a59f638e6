"""Ontology benchmark: build time vs. a naive rdflib build, D per skill, scaling with embodiments.

    .venv/bin/python -m benchmarks.ontology_bench [--repeats 30] [--json out.json]

Targets (issue "Skill ontology"): full build median <= 0.08 s; D median <= 5 ms; build time grows
no worse than linearly with 10x and 50x synthetic embodiments.
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import tempfile
import time
from pathlib import Path

import yaml

from lerobot_policy_recent.ontology.builder import RC, EmbodimentSource, build_ontology, default_embodiment_sources
from lerobot_policy_recent.ontology.diagnosis import diagnose
from lerobot_policy_recent.skills.repository import list_skills, load_skill


def timed(fn, repeats: int) -> list[float]:
    fn()  # warm-up: imports, file cache
    out = []
    for _ in range(repeats):
        started = time.perf_counter()
        fn()
        out.append(time.perf_counter() - started)
    return out


def naive_rdflib_build() -> int:
    """The same graph in rdflib, with substitutableBy derived by one SPARQL ASK per primitive pair and rule."""
    import rdflib

    onto = build_ontology()
    graph = rdflib.Graph()
    graph.parse(data=onto.to_turtle(), format="turtle")
    for triple in list(graph.triples((None, rdflib.URIRef(RC + "substitutableBy"), None))):
        graph.remove(triple)
    prims = [row[0] for row in graph.query(f"SELECT ?p WHERE {{ ?r <{RC}hasPrimitive> ?p }}")]
    same = f"""ASK {{ ?a <{RC}hasEffect> ?e . FILTER NOT EXISTS {{ ?b <{RC}hasEffect> ?e }} }}"""
    added = 0
    for a in prims:
        for b in prims:
            if a == b:
                continue
            differs = (
                graph.query(same, initBindings={"a": a, "b": b}).askAnswer
                or graph.query(same, initBindings={"a": b, "b": a}).askAnswer
            )
            if not differs:
                graph.add((a, rdflib.URIRef(RC + "substitutableBy"), b))
                added += 1
    return added


def synthetic_embodiments(factor: int, root: Path) -> list[EmbodimentSource]:
    """``factor`` copies of every target embodiment (renamed), next to the real source robot."""
    out = []
    for src in default_embodiment_sources():
        if src.source:
            out.append(src)
            continue
        spec = yaml.safe_load(src.api_spec.read_text())
        for i in range(factor):
            name = f"{src.name}_{i}"
            path = root / f"{name}.yaml"
            path.write_text(yaml.safe_dump({**spec, "embodiment": name}))
            out.append(EmbodimentSource(name, path, src.robot_mjcf, src.gripper_mjcf))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeats", type=int, default=30)
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()

    results: dict[str, object] = {
        "machine": f"{platform.processor() or platform.machine()}, {platform.python_version()}",
        "date": time.strftime("%Y-%m-%d"),
    }
    skills = [load_skill(n) for n in list_skills()]
    onto = build_ontology()
    stats = onto.stats()
    build = timed(build_ontology, args.repeats)
    naive = timed(naive_rdflib_build, 3)
    targets = [r for r in onto.robot_names() if r != "Panda"]
    d_times = timed(lambda: [diagnose(onto, s.name, s.code, r) for s in skills for r in targets], args.repeats * 5)
    per_d = [t / (len(skills) * len(targets)) for t in d_times]
    results |= {
        "scale": stats,
        "build_median_s": statistics.median(build),
        "naive_rdflib_median_s": statistics.median(naive),
        "d_median_ms": 1000 * statistics.median(per_d),
    }

    scaling = {}
    with tempfile.TemporaryDirectory() as tmp:
        for factor in (1, 10, 50):
            sources = synthetic_embodiments(factor, Path(tmp))
            times = timed(lambda sources=sources: build_ontology(sources), max(3, args.repeats // 6))
            scaling[factor] = {"embodiments": len(sources), "median_s": statistics.median(times)}
    base = scaling[1]
    for entry in scaling.values():
        entry["s_per_embodiment"] = entry["median_s"] / entry["embodiments"]
        entry["vs_linear"] = entry["s_per_embodiment"] / (base["median_s"] / base["embodiments"])
    results["scaling"] = scaling

    print(f"ontology benchmark — {results['machine']} — {results['date']}")
    print(f"scale: {json.dumps(stats)}")
    print("| measure | value | target |")
    print("|---|---|---|")
    print(f"| full build, median of {args.repeats} | {results['build_median_s'] * 1000:.1f} ms | <= 80 ms |")
    print(
        f"| naive rdflib build (SPARQL ASK per pair), median of 3 | {results['naive_rdflib_median_s'] * 1000:.0f} ms | ratio {results['naive_rdflib_median_s'] / results['build_median_s']:.0f}x slower |"
    )
    print(f"| D per skill x robot, median | {results['d_median_ms']:.2f} ms | <= 5 ms |")
    for factor, entry in scaling.items():
        print(
            f"| build with {entry['embodiments']} embodiments ({factor}x targets) | {entry['median_s'] * 1000:.0f} ms ({entry['vs_linear']:.2f}x linear) | <= 1.0x linear |"
        )
    if args.json:
        args.json.write_text(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
