"""A submission's resource disclosure (issue 22 §7): checked by ``load_campaign`` and
``eagc check-files --disclosure``, kept beside the pinned image, shown in the organizer's
report and the audit (a missing one as missing, never an error)."""

from __future__ import annotations

import json
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest
from typer.testing import CliRunner

from orchestrator._campaign.audit import TeamAudit, report_lines
from orchestrator._campaign.disclosure import (
    FOLDER,
    disclosure_problems,
    keep_disclosures,
    kept_disclosures,
    read_disclosure,
)
from orchestrator._campaign.spec import campaign_dir, load_campaign, store_path
from orchestrator.cli.main import app
from schemas import ResourceDisclosure, SchemaError

EXAMPLES = Path(__file__).parents[2] / "examples" / "campaigns"
BROKEN = """\
version: eagc-disclosure/v1
data:
  - {name: a, kind: publik}
  - {name: b}
pretrained_model: []
compute: {gpu_hours: -1}
dependencies: [{name: numpy, licence: BSD}]
"""


@pytest.fixture
def runs() -> Iterator[Path]:
    """A short output folder (episode sockets limit its length)."""
    path = Path(tempfile.mkdtemp(prefix="eagc-d-"))
    yield path
    shutil.rmtree(path, ignore_errors=True)


def _campaign(tmp_path: Path, disclosure: str | None, runs: Path, *, team_b: str = ""
              ) -> Path:
    sub = f", disclosure: {disclosure}" if disclosure else ""
    text = f"""\
name: disc-test
track: sanity
phase: local
splits: [{{name: standard, episodes: 1}}]
submissions:
  - {{team: alpha, image: "eagc/sanity-agent:latest"{sub}}}
  - {{team: beta, image: "eagc/sanity-agent:latest"{team_b}}}
output: {runs}
runtime: local
"""
    path = tmp_path / "campaign.yaml"
    path.write_text(text)
    return path


def test_the_example_disclosures_validate() -> None:
    files = sorted(EXAMPLES.glob("*.disclosure.*"))
    assert len(files) >= 3
    for f in files:
        assert disclosure_problems(f) == [], f
        assert isinstance(read_disclosure(f), ResourceDisclosure)


def test_every_problem_at_its_path_unknown_keys_first(tmp_path: Path, runs: Path) -> None:
    bad = tmp_path / "team.disclosure.yaml"
    bad.write_text(BROKEN)
    lines = disclosure_problems(bad)
    assert lines[:2] == [
        "pretrained_model: unknown key: no field takes it (did you mean "
        "'pretrained_models'?)",
        "dependencies.0.licence: unknown key: no field takes it (did you mean 'license'?)"]
    assert "data.0.kind: Input should be 'public', 'private' or 'synthetic'; got 'publik': "\
        "did you mean 'public'?" in lines
    assert "data.1.kind: Field required" in lines
    assert "compute.description: Field required" in lines
    assert "compute.gpu_hours: Input should be greater than or equal to 0" in lines
    assert not any(line.startswith("not graded") for line in lines)
    (tmp_path / "d.json").write_text("{")
    assert disclosure_problems(tmp_path / "d.json")[0].startswith("not valid JSON")
    assert "cannot read" in disclosure_problems(tmp_path / "nope.yaml")[0]


def test_load_campaign_resolves_and_checks_the_disclosure(tmp_path: Path, runs: Path) -> None:
    (tmp_path / "team.disclosure.yaml").write_text(
        (EXAMPLES / "baselines.disclosure.yaml").read_text())
    spec = load_campaign(_campaign(tmp_path, "team.disclosure.yaml", runs))
    assert spec.submissions[0].disclosure == (tmp_path / "team.disclosure.yaml").resolve()
    assert spec.submissions[1].disclosure is None
    (tmp_path / "team.disclosure.yaml").write_text(BROKEN)
    with pytest.raises(SchemaError) as e:
        load_campaign(_campaign(tmp_path, "team.disclosure.yaml", runs))
    assert "submissions.0.disclosure: team.disclosure.yaml: data.1.kind: Field required" \
        in e.value.problems


def test_kept_beside_the_pinned_image_and_read_back(tmp_path: Path, runs: Path) -> None:
    src = tmp_path / "alpha.disclosure.yaml"
    src.write_text((EXAMPLES / "track1_priors.disclosure.yaml").read_text())
    spec = load_campaign(_campaign(tmp_path, src.name, runs))
    folder = campaign_dir(spec)
    before = kept_disclosures(spec, folder)
    assert before["alpha"].status == "ok" and not before["alpha"].kept
    assert before["beta"].status == "missing"
    pinned = {"alpha": SimpleNamespace(run="sha256:" + "a" * 64, digest="sha256:" + "a" * 64),
              "beta": SimpleNamespace(run="sha256:" + "b" * 64, digest="sha256:" + "b" * 64)}
    written = keep_disclosures(spec, pinned, folder)
    assert {p.name for p in written} == {"alpha.json", "alpha.disclosure.yaml", "beta.json"}
    assert (folder / FOLDER / "alpha.disclosure.yaml").read_bytes() == src.read_bytes()
    src.write_text(BROKEN)  # what the campaign kept is what it shows, not today's file
    after = kept_disclosures(spec, folder)
    alpha = after["alpha"]
    assert alpha.kept and alpha.status == "ok" and alpha.digest == "sha256:" + "a" * 64
    assert alpha.disclosure is not None and alpha.disclosure.data[0].kind == "synthetic"
    assert after["beta"].status == "missing" and after["beta"].image == "sha256:" + "b" * 64
    stored = json.loads((folder / FOLDER / "alpha.json").read_text())
    assert stored["sha256"].startswith("sha256:") and stored["source"] == str(src.resolve())


def _eagc(*args: str) -> Any:
    return CliRunner().invoke(app, ["check-files", *args], env={"COLUMNS": "80"})


def test_check_files_disclosure(tmp_path: Path, runs: Path) -> None:
    r = _eagc("--disclosure", str(EXAMPLES / "track2_imitation.disclosure.yaml"))
    assert r.exit_code == 0, r.output
    assert "track2_imitation.disclosure.yaml: ok" in r.stdout
    assert "scripted expert rollouts" in r.stdout
    bad = runs / "team.disclosure.yaml"  # a short path: the report's lines fit 80 columns
    bad.write_text(BROKEN)
    r = _eagc("--disclosure", str(bad))
    assert r.exit_code == 1, r.output
    text = " ".join(r.stdout.split())
    assert "team.disclosure.yaml: FAILS (7 lines)" in text
    assert "data.1.kind: Field required" in text
    assert "a valid ResourceDisclosure:" in text
    assert "resource_disclosure.json" in text
    assert all(len(line) <= 80 for line in r.stdout.splitlines())
    assert _eagc("--disclosure", str(tmp_path / "nope.yaml")).exit_code == 2
    assert _eagc().exit_code == 2
    assert _eagc(str(tmp_path)).exit_code == 2  # a folder needs --track


def test_the_audit_shows_it_and_a_missing_one_is_not_a_flag(tmp_path: Path, runs: Path) -> None:
    src = runs / "alpha.disclosure.yaml"  # a short path: the report's lines fit 80 columns
    src.write_text((EXAMPLES / "track2_imitation.disclosure.yaml").read_text())
    spec = load_campaign(_campaign(tmp_path, str(src), runs))
    kept = kept_disclosures(spec, campaign_dir(spec))
    for team, words in (("alpha", "data: scripted expert rollouts"),
                        ("beta", "missing: the submission names no resource disclosure")):
        audit = TeamAudit(campaign=spec.name, track=spec.track, team=team, image="img",
                          episodes=(), disclosure=kept[team])
        lines = report_lines(audit)
        assert audit.clean
        assert "Resource disclosure (paper Table VIII)" in lines
        assert any(line.startswith(words) for line in lines), lines
        assert all(len(line) <= 80 for line in lines)
        assert TeamAudit.model_validate_json(audit.model_dump_json()) == audit


def test_the_organizer_index_shows_each_teams_disclosure(tmp_path: Path, runs: Path) -> None:
    from orchestrator._results.store import ResultsStore
    from orchestrator._viewer import write_campaign_site

    src = tmp_path / "alpha.disclosure.yaml"
    src.write_text((EXAMPLES / "track1_priors.disclosure.yaml").read_text())
    spec = load_campaign(_campaign(tmp_path, src.name, runs))
    with ResultsStore(store_path(spec)) as store:
        write_campaign_site(spec, store, tmp_path / "org", organizer=True)
        write_campaign_site(spec, store, tmp_path / "pub")
    org = (tmp_path / "org" / "index.html").read_text()
    assert "Resource disclosures" in org
    assert "eagc generated houses (doorway choice) (synthetic, Apache-2.0)" in org
    assert org.count('class="disclosure-row"') == 2
    assert "the submission names no resource disclosure" in org
    pub = (tmp_path / "pub" / "index.html").read_text()
    assert "Resource disclosures" not in pub and "doorway choice" not in pub
