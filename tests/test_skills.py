"""The offline skill repository: committed validation records, refusal of unvalidated code, the CLI."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from lerobot_policy_recent.descriptions.embodiments import SOURCE_EMBODIMENTS
from lerobot_policy_recent.recent_plugin.authoring.sim_validation import validate
from lerobot_policy_recent.recent_plugin.settings import RecentSettings
from lerobot_policy_recent.robosuite_envs.splits import DEV_SEEDS
from lerobot_policy_recent.robosuite_envs.suites import SEEDS
from lerobot_policy_recent.skills.records import load_record
from lerobot_policy_recent.skills.repository import (
    LIBRARY,
    SkillNotValidatedError,
    derived_capabilities,
    list_skills,
    load_skill,
    records_dir,
    serve_skill,
)


def test_every_stored_skill_passed_validate_on_all_five_seeds_with_its_current_code():
    for name in list_skills():
        skill, record = load_skill(name), load_record(name)
        assert record is not None, f"{name}: no validation record"
        assert record.code_sha256 == skill.code_sha256, f"{name}: edited since validation"
        assert record.robot == skill.source_embodiment and sorted(record.passed) == sorted(record.seeds), name
        assert skill.source_embodiment in SOURCE_EMBODIMENTS, name
        # the -v1 suites' skills on the paper's seeds; those of the paper-length suites' subtasks on the dev seeds
        assert sorted(record.seeds) in (sorted(SEEDS), sorted(DEV_SEEDS)), name
        assert serve_skill(name).code == skill.code


def test_each_setting_has_its_skills_written_for_its_own_source_api():
    """The paper's two settings, as it defines them: kinematic skills call the Panda's position-based
    API, end-effector skills the Franka Hand's name-based one (``pick(obj_name=...)``)."""
    from lerobot_policy_recent.robosuite_envs.suites import SUITES

    for suite, source in (("kinematic", "Panda"), ("end_effector", "FrankaHand")):
        for name in {step.skill for task in SUITES[suite] for step in task.plan}:
            assert load_skill(name).source_embodiment == source, (suite, name)
    assert "pick(env, task, obj_name=" in load_skill("fill_box").code


def test_metadata_declares_the_capabilities_its_call_sites_need():
    for name in list_skills():
        skill = load_skill(name)
        assert skill.capabilities and list(skill.capabilities) == derived_capabilities(skill), name


@pytest.fixture
def library_copy(tmp_path):
    shutil.copytree(LIBRARY, tmp_path / "library")  # validation records included
    return tmp_path / "library"


def test_an_edited_skill_is_refused_until_revalidated(library_copy):
    path = library_copy / "stack.py"
    path.write_text(path.read_text().replace("+ 0.055", "+ 0.06"))
    with pytest.raises(SkillNotValidatedError, match="code changed since it was validated.*recent skills validate"):
        serve_skill("stack", library_copy)
    assert serve_skill("stack", library_copy, require_validated=False).code == path.read_text()  # the ablation


def test_malformed_metadata_names_the_file_and_the_field(library_copy):
    meta = library_copy / "stack.yaml"
    meta.write_text(meta.read_text().replace("capabilities: [", "capabilities: grasp [", 1))
    with pytest.raises(ValueError, match=r"stack.yaml: field 'capabilities' must be a list"):
        load_skill("stack", library_copy)


def test_a_skill_without_a_record_is_refused(library_copy):
    (records_dir(library_copy) / "wipe_area.json").unlink()
    with pytest.raises(SkillNotValidatedError, match="never validated"):
        serve_skill("wipe_area", library_copy)


def test_validate_runs_the_skill_on_panda_over_the_seeds_and_records_why():
    record = validate(load_skill("press_button"), seeds=(0, 1))
    assert record.validated and record.passed == [0, 1] and record.task == "kinematic/press_button"
    assert set(record.seconds) == {"0", "1"} and not record.failures


def test_validate_says_why_a_skill_it_could_not_run_failed(library_copy):
    """A skill the security gate refuses as written (here, a docstring over its 200-character limit)
    fails validation with the gate's reason, not with "the success predicate never held"."""
    path = library_copy / "press_button.py"
    path.write_text(path.read_text().replace('"""', '"""' + "Press it. " * 25, 1))
    record = validate(load_skill("press_button", library_copy), seeds=(0,))
    assert not record.passed and "string literal too long" in record.failures["0"]


def test_skills_list_json_has_the_documented_fields(capsys):
    from lerobot_policy_recent.scripts.cli import main

    assert main(["skills", "list", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert {r["name"] for r in rows} == set(list_skills())
    for row in rows:
        assert set(row) == {"name", "library", "subtask", "source", "validated", "code_sha256", "seeds_passed"}
        assert row["source"] in SOURCE_EMBODIMENTS
        assert row["validated"] and row["seeds_passed"] in (sorted(SEEDS), sorted(DEV_SEEDS))


def test_skills_show_prints_code_metadata_and_last_validation(capsys):
    from lerobot_policy_recent.scripts.cli import main

    assert main(["skills", "show", "open_drawer"]) == 0
    out = capsys.readouterr().out
    assert "def open_drawer(" in out and "# effects:" in out and "seeds passed [0, 1, 42, 123, 2024]" in out
    assert "# leaves: drawer state at least 0.1" in out
    assert main(["skills", "show", "arrange_in_row"]) == 0
    assert "# leaves: first over row; second over row; third over row" in capsys.readouterr().out


@pytest.mark.parametrize(
    "entry",
    [
        "{object: knob, at_least: 0.1}",
        "{object: drawer}",
        "{object: drawer, at_least: 0.1, at_most: 0.2}",
        "{object: drawer, at_least: open}",
        "drawer",
        "{object: [drawer], at_least: 0.1}",
    ],
)
def test_a_state_effect_must_name_a_parameter_and_one_bound(tmp_path, entry):
    """``state_effects`` entries are checked when the skill loads: the file, the field and the entry are named."""
    import shutil

    from lerobot_policy_recent.skills import repository

    library = tmp_path / "library"
    shutil.copytree(repository.LIBRARY, library)
    meta = library / "open_drawer.yaml"
    meta.write_text(meta.read_text().split("state_effects:")[0] + f"state_effects: [{entry}]\n")
    with pytest.raises(
        ValueError,
        match=r"open_drawer\.yaml: field 'state_effects' entry .* must be \{object: <one of \['drawer'\]>",
    ):
        repository.load_skill("open_drawer", library)


def test_a_broken_skill_file_disables_that_skill_not_the_commands(tmp_path, monkeypatch, capsys):
    """A malformed YAML leaves its skill out, with the file and the field named; the rest keeps working."""
    import shutil

    from lerobot_policy_recent.scripts import ontology_cmd
    from lerobot_policy_recent.scripts.cli import main
    from lerobot_policy_recent.skills import repository

    library = tmp_path / "library"
    shutil.copytree(repository.LIBRARY, library)
    (library / "wipe_area.yaml").write_text("entry: wipe_area\nsubtask: wipe\n")  # no source_embodiment, intent
    skills, broken = repository.load_skills(library)
    assert "wipe_area" in broken and "missing field(s) source_embodiment, intent" in broken["wipe_area"]
    assert "wipe_area.yaml" in broken["wipe_area"] and len(skills) == len(repository.list_skills(library)) - 1

    monkeypatch.setattr(repository, "LIBRARY", library)
    monkeypatch.setattr(ontology_cmd, "load_skills", lambda: repository.load_skills(library))
    assert main(["ontology", "stats"]) == 0
    assert "skill 'wipe_area' is left out" in capsys.readouterr().err
    assert main(["skills", "list", "--skill_library", str(library)]) == 0
    assert "wipe_area          BROKEN:" in capsys.readouterr().out


def test_a_placement_must_name_two_parameters(tmp_path):
    import shutil

    from lerobot_policy_recent.skills import repository

    library = tmp_path / "library"
    shutil.copytree(repository.LIBRARY, library)
    meta = library / "move_to_region.yaml"
    assert repository.load_skill("move_to_region", library).placements[0].over == "region"
    meta.write_text(meta.read_text().split("placements:")[0] + "placements: [{object: obj, over: [zone]}]\n")
    with pytest.raises(
        ValueError, match=r"move_to_region\.yaml: field 'placements' entry .* each one of \['obj', 'region'\]"
    ):
        repository.load_skill("move_to_region", library)
    meta.write_text(meta.read_text().split("placements:")[0] + "placements: [{object: obj, over: region, at: [0.1]}]\n")
    with pytest.raises(ValueError, match=r"move_to_region\.yaml: field 'placements' entry .*'at' must be \[dx, dy\]"):
        repository.load_skill("move_to_region", library)
    meta.write_text(
        meta.read_text().split("placements:")[0] + "placements: [{object: obj, over: region, at: [0, 0.1]}]\n"
    )
    assert repository.load_skill("move_to_region", library).placements[0].at == (0.0, 0.1)
    meta.write_text(meta.read_text().split("placements:")[0] + "placements: [{object: obj, over: region, inside: 1}]\n")
    with pytest.raises(ValueError, match=r"move_to_region\.yaml: field 'placements' entry .*'inside' must be true or"):
        repository.load_skill("move_to_region", library)
    meta.write_text(
        meta.read_text().split("placements:")[0] + "placements: [{object: obj, over: region, inside: true}]\n"
    )
    assert repository.load_skill("move_to_region", library).placements[0].inside
    assert repository.load_skill("sweep_into_pen").placements[0].inside  # a pen's, a bin's walls hold it all


EXAMPLES = Path(__file__).parents[1] / "examples" / "skills"  # the README's own skill, outside the bundled library


def test_a_users_library_serves_its_skill_in_place_of_the_bundled_one_and_the_rest_as_bundled(tmp_path):
    """``--skill_library``: a skill of the user's directory replaces the bundled one of its name, with the
    record beside it; the rest of a task's plan is still served, so a library of one skill runs a task."""
    from lerobot_policy_recent.skills.repository import served_skills, skill_home, task_calls

    mine = serve_skill("put_in_bin", EXAMPLES)
    assert mine.path == EXAMPLES / "put_in_bin.py" and mine.code != load_skill("put_in_bin").code
    assert skill_home("stack", EXAMPLES) == LIBRARY and serve_skill("stack", EXAMPLES).code == load_skill("stack").code
    assert served_skills(EXAMPLES) == list_skills()  # one replaced, none added
    assert task_calls(["put_in_bin", "stack"], EXAMPLES).primitives == task_calls(["put_in_bin", "stack"]).primitives
    shutil.copytree(EXAMPLES, tmp_path / "mine")
    (tmp_path / "mine" / "validation" / "put_in_bin.json").unlink()
    with pytest.raises(SkillNotValidatedError, match=r"mine/put_in_bin.py\) is not served: it was never validated"):
        serve_skill("put_in_bin", tmp_path / "mine")
    with pytest.raises(KeyError, match="unknown skill 'nope'; known skills: arrange_in_row"):
        serve_skill("nope", tmp_path / "mine")


def test_the_skills_commands_read_a_users_library_and_name_a_bad_one(capsys, tmp_path):
    from lerobot_policy_recent.scripts.cli import main

    assert main(["skills", "list", "--json", "--skill_library", str(EXAMPLES)]) == 0
    rows = {row["name"]: row for row in json.loads(capsys.readouterr().out)}
    assert rows["put_in_bin"]["library"] == str(EXAMPLES) and rows["put_in_bin"]["validated"]
    assert rows["stack"]["library"] == str(LIBRARY)
    assert main(["skills", "show", "put_in_bin", "--skill_library", str(EXAMPLES)]) == 0
    assert "near_side = [" in capsys.readouterr().out
    with pytest.raises(SystemExit) as exit_:
        main(["skills", "list", "--skill_library", str(tmp_path / "absent")])
    assert (
        exit_.value.code == 2
        and "--skill_library: 'PATH' is not a directory".replace("PATH", str(tmp_path / "absent"))
        in capsys.readouterr().err
    )
    with pytest.raises(ValueError, match="--skill_library: .* is not a directory"):
        RecentSettings(skill_library=str(tmp_path / "absent"))
    shutil.copytree(EXAMPLES, tmp_path / "mine")
    meta = tmp_path / "mine" / "put_in_bin.yaml"
    meta.write_text(meta.read_text().replace("subtask: put_in_bin", "subtask: put_in_pocket"))
    assert main(["skills", "validate", "--skill_library", str(tmp_path / "mine")]) == 2  # before any episode
    assert f"{meta}: field 'subtask': 'put_in_pocket' has no single-subtask task" in capsys.readouterr().err


@pytest.mark.slow
def test_validate_writes_a_users_record_into_their_library(tmp_path, capsys):
    from lerobot_policy_recent.scripts.cli import main

    shutil.copytree(EXAMPLES, tmp_path / "mine")
    (tmp_path / "mine" / "validation" / "put_in_bin.json").unlink()
    assert main(["skills", "validate", "--skill_library", str(tmp_path / "mine")]) == 0
    assert f"1/1 skill(s) validated; records in {tmp_path / 'mine' / 'validation'}" in capsys.readouterr().out
    assert serve_skill("put_in_bin", tmp_path / "mine").path.parent == tmp_path / "mine"
    assert load_record("put_in_bin") is not None  # the bundled record is untouched
