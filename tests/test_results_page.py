"""The committed results page and the README's verdict table come from the same reproduce run."""

from __future__ import annotations

import json
import re
import shutil
from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import pandas as pd
import pytest

from gym4real.bench import stats
from gym4real.bench.numbers import human, human_interval
from gym4real.bench.upper_label import label
from gym4real.core.registry import registry
from gym4real.results.analysis import analyse
from gym4real.results.headroom_page import HEADER as HEADROOM_HEADER
from gym4real.results.results_page import write_page

ROOT = Path(__file__).resolve().parents[1]


#: A verdict's mark on the page (results_page.SYMBOLS).
MARKS = {"holds": "✅", "refuted": "❌", "inconclusive": "❔"}


def _verdict_rows(text: str) -> list[str]:
    """The rows of the short verdict tables: env (budget under it), claim, verdict with its mark, difference."""
    return [line for line in text.splitlines() if re.match(r"\| `[a-z0-9-]+`(<br>[^|]*)? \| [^|]+ \| [✅❌❔] ", line)]


def _verdict_details(text: str) -> list[str]:
    """The lines of the details blocks under the verdict tables: each claim in full, in the table's order."""
    return [line for line in text.splitlines() if re.match(r"- `[a-z0-9-]+`: .+\. Verdict: [✅❌❔] ", line)]


def test_the_readme_verdicts_are_the_results_pages() -> None:
    readme = _verdict_rows((ROOT / "README.md").read_text(encoding="utf-8"))
    page = _verdict_rows((ROOT / "docs" / "results" / "index.md").read_text(encoding="utf-8"))
    assert readme and readme == page


def test_every_figure_the_results_page_shows_is_committed() -> None:
    page = ROOT / "docs" / "results"
    links = re.findall(r"\]\(([^)]+\.png)\)", (page / "index.md").read_text(encoding="utf-8"))
    assert links
    for link in links:
        assert (page / link).read_bytes()[:4] == b"\x89PNG", link


def test_each_env_page_shows_its_verdicts_from_the_results_page(load_script: Callable[[Path], ModuleType]) -> None:
    gen_pages = load_script(ROOT / "docs" / "gen_pages.py")
    page = _verdict_rows((ROOT / "docs" / "results" / "index.md").read_text(encoding="utf-8"))
    for env_id in ("gym4real/dam-v0", "gym4real/wds-v0"):
        section = gen_pages._reproduction(env_id)
        assert section[0] == "## Reproduction" and "(../results/index.md)" in section[2]
        name = env_id.split("/")[-1]
        # the env's rows, those of another trainer's section too (its agent under the env's name)
        assert _verdict_rows("\n".join(section)) == [row for row in page if re.match(rf"\| `{name}`(<br>|\s\|)", row)]
    assert gen_pages._reproduction("gym4real/no-such-v0") == []


def _results_folder(out: Path, budget: str, version: str = "v1.0-3-gabc1234") -> Path:
    """A wds results folder as ``reproduce`` writes it, with made-up scores: p79 is p78, dqn seed 1 failed."""
    rng = np.random.default_rng(0)
    folder = out / f"wds-v0-{budget}"
    folder.mkdir(parents=True)
    p78 = rng.normal(20, 100, 20)
    rows = {"random": rng.normal(80, 60, 20), "p78": p78, "p79": p78.copy(), "default": rng.normal(160, 5, 20)}
    frame = [
        {"policy": name, "seed": None, "episode": i, "objective": v, "return": v, "dsr": v + 50.0, "overflow": -50.0}
        for name, values in rows.items()
        for i, v in enumerate(values)
    ]
    for seed, centre in ((0, 150.0), (1, 60.0), (2, 158.0)):
        frame += [
            {
                "policy": "dqn",
                "seed": seed,
                "episode": i,
                "objective": v,
                "return": v,
                "dsr": v + 50.0,
                "overflow": -50.0,
            }
            for i, v in enumerate(rng.normal(centre, 3, 20))
        ]
    episodes = pd.DataFrame(frame)
    episodes["seed"] = episodes["seed"].astype("Int64")
    episodes.to_csv(folder / "episodes.csv", index=False)
    pd.DataFrame(
        [
            {
                "algo": "dqn",
                "seed": s,
                "preset": "paper",
                "total_timesteps": 1000,
                "episodes": None,
                "env_steps": 1000,
                "eval_steps": 100,
                "wall_s": 10.0,
                "env_steps_per_s": 110.0,
                "learning_rate": "0.0001",
                "selected_unit": "timesteps",
                "selected_at": 500 + s,
                "selected_validation_return": 1.0,
                "settings": "{}",
            }
            for s in (0, 1, 2)
        ]
    ).to_csv(folder / "runs.csv", index=False)
    report = {
        "env_id": "gym4real/wds-v0",
        "budget": budget,
        "command": f"gym4real reproduce gym4real/wds-v0 --budget {budget} --seeds 3 --out results/{budget}",
        "objective": ["dsr", "overflow"],
        "protocol": "test profiles 0..19",
        "step_unit": "hour",
        "seeds": [0, 1, 2],
        "presets": {"dqn": "paper"},
        "test_wall_time_s": 4.0,
        "code_version": version,
        "versions": {"gym4real-core": "0.2.0"},
        "platform": "Linux",
        "data_files": [{"name": "wds/network", "path": "wds/net.inp", "sha256": "0" * 64, "found": "user cache"}],
    }
    (folder / "report.json").write_text(json.dumps(report))
    analyse(folder, "gym4real/wds-v0", budget)
    return folder


def _jax_section(out: Path, budget: str) -> Path:
    """:func:`_results_folder`'s runs as a section of the JAX trainer's (``wds-v0-<budget>-jax``, agent ``ppo-jax``)."""
    folder = _results_folder(out / "made", budget).rename(out / f"wds-v0-{budget}-jax")
    for name, column in (("episodes.csv", "policy"), ("runs.csv", "algo")):
        frame = pd.read_csv(folder / name)
        frame[column] = frame[column].replace("dqn", "ppo-jax")
        frame.to_csv(folder / name, index=False)
    report = json.loads((folder / "report.json").read_text())
    report["presets"], report["command"] = {"ppo-jax": budget}, report["command"] + " --trainer jax"
    (folder / "report.json").write_text(json.dumps(report))
    analyse(folder, "gym4real/wds-v0", budget)
    (out / "made").rmdir()
    return folder


def _with_fingerprints(folder: Path, trainer: str) -> None:
    """Record the installed fingerprints of ``trainer``'s section in ``folder``'s report."""
    from gym4real.results.fingerprints import KEY, fingerprints

    report = json.loads((folder / "report.json").read_text())
    report[KEY] = fingerprints(report["env_id"], report["budget"], trainer)
    (folder / "report.json").write_text(json.dumps(report))


def test_a_jax_section_is_a_section_of_its_own_labelled_by_its_trainer(tmp_path: Path) -> None:
    out, page = tmp_path / "out", tmp_path / "page"
    sb3, jax = _results_folder(out, "paper"), _jax_section(out, "paper")
    text = write_page(out, page).read_text()
    heading = "## `gym4real/wds-v0`, budget `paper`, trainer `ppo-jax` (PPO trained by JAX)"
    assert text.index("## `gym4real/wds-v0`, budget `paper`\n") < text.index(heading)
    own = text[text.index(heading) :]
    assert "| ppo-jax | 3 | 20 |" in own and "| dqn | 3 |" not in own and "--trainer jax" in own
    assert "| ppo-jax | 3 | " in text and text.count("`gym4real/wds-v0`: 0 = random") == 1  # suite score
    # wds's claims are about `dqn`, which the JAX trainer does not train: its section's claims are not checked,
    # shown in its own section alone; the page's verdicts are the SB3 section's (and no trainer comparison)
    assert {c["verdict"] for c in json.loads((jax / "claims.json").read_text())} == {"not checked"}
    assert "| ➖ **not checked** |" in own and "trainer against SB3" not in text
    assert json.loads((page / "claims.json").read_text()) == json.loads((sb3 / "claims.json").read_text())
    manifest = json.loads((page / "manifest.json").read_text())
    assert set(manifest["provenance"]) == {sb3.name, jax.name}
    from gym4real.results.artefacts import verify

    assert verify(page).problems == {}
    (page / jax.name / "summary.csv").write_text("changed")
    problems = verify(page).problems
    assert list(problems) == [jax.name] and problems[jax.name][0].startswith(f"{jax.name}/summary.csv changed")
    shutil.copy(jax / "summary.csv", page / jax.name / "summary.csv")
    assert write_page(page, page).read_text() == text  # the page folder alone regenerates the page


def test_a_jax_section_alone_shows_its_quick_budget(tmp_path: Path) -> None:
    out = tmp_path / "out"
    _jax_section(out, "quick")
    text = write_page(out).read_text()
    assert "## `gym4real/wds-v0`, budget `quick`, trainer `ppo-jax` (PPO trained by JAX): pipeline check" in text


def test_the_check_compares_a_jax_section_with_the_jax_trainers_fingerprints(tmp_path: Path) -> None:
    from gym4real.results.currency import check
    from gym4real.results.fingerprints import JAX_TRAINER_VERSION, fingerprints

    out, page = tmp_path / "out", tmp_path / "page"
    sb3, jax = _results_folder(out, "paper"), _jax_section(out, "paper")
    _with_fingerprints(sb3, "sb3")
    _with_fingerprints(jax, "jax")
    recorded = json.loads((jax / "report.json").read_text())["fingerprints"]["trainer"]
    assert recorded["trainer"] == "jax" and recorded["trainer_version"] == JAX_TRAINER_VERSION
    assert {"jax", "jaxlib", "optax", "numba"} <= set(recorded) and "torch" not in recorded
    assert "trainer" not in fingerprints("gym4real/wds-v0", "paper")["trainer"]  # the reference's, as it always was
    write_page(out, page)
    found = check(page)
    assert found.lines == [f"{sb3.name}: current", f"{jax.name}: current"] and not found.damaged
    _with_fingerprints(jax, "sb3")  # a JAX section that recorded the reference trainer's fingerprints
    write_page(out, page)
    (line,) = [line for line in check(page).lines if line.startswith(jax.name)]
    assert line.startswith(f"{jax.name}: stale: ") and "trainer.trainer: new" in line


def test_stale_reruns_a_jax_section_by_its_trainer_and_moves_aside_its_runs_alone(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from gym4real.results import currency, reproduce

    out = tmp_path / "out"
    _jax_section(out, "paper")  # no fingerprints recorded: stale, trained again
    runs = out / "wds-v0" / "paper" / "runs"
    for agent in ("dqn", "ppo-jax"):
        (runs / agent / "seed0").mkdir(parents=True)
    calls: list[tuple[Any, ...]] = []
    monkeypatch.setattr(reproduce, "reproduce", lambda *args, **kwargs: calls.append((args, kwargs)) or "rerun")
    said = currency.reproduce_stale(out)
    assert said.startswith("wds-v0-paper-jax: stale (no fingerprints recorded); its runs moved to runs.stale-")
    (aside,) = runs.parent.glob("runs.stale-*")
    assert [p.name for p in aside.iterdir()] == ["ppo-jax"] and (runs / "dqn" / "seed0").is_dir()  # SB3's stay
    ((args, kwargs),) = calls
    assert args[:2] == (["gym4real/wds-v0"], "paper") and kwargs["trainer"] == "jax"


def _matrices(path: Path) -> tuple[dict[str, np.ndarray], set[str]]:
    """Policy -> (seeds, episodes) objective matrix read with plain pandas, and the policies with seeds."""
    frame = pd.read_csv(path)
    scores, trained = {}, set()
    for policy, rows in frame.groupby("policy", sort=False):
        if rows["seed"].notna().any():
            trained.add(str(policy))
            scores[str(policy)] = rows.pivot(index="seed", columns="episode", values="objective").to_numpy()
        else:
            scores[str(policy)] = rows.sort_values("episode")["objective"].to_numpy()[None, :]
    return scores, trained


def test_every_number_of_the_page_is_recomputed_from_episodes_csv(tmp_path: Path) -> None:
    out = tmp_path / "out"
    folder = _results_folder(out, "paper")
    text = write_page(out, tmp_path / "page").read_text()
    scores, trained = _matrices(folder / "episodes.csv")
    assert trained == {"dqn"} and scores["dqn"].shape == (3, 20)
    scale = max(float(np.abs(m).max()) for m in scores.values())
    for name, matrix in scores.items():
        iqm, low, high = stats.iqm_ci(matrix, name in trained)
        assert f"| {name} | " in text and f"| {human(iqm)} | {human_interval(low, high)} |" in text, name
    seed_iqms, _ = stats.per_seed(scores["dqn"])
    for seed, value in enumerate(seed_iqms):  # the failed seed shows, with its checkpoint
        assert f"| dqn | {seed} | {human(value)} |" in text and f"{500 + seed:,} timesteps" in text
    for base in ("random", "p78", "p79", "default"):
        p, low, high = stats.probability_of_improvement(scores["dqn"], scores[base], True, False)
        assert f"| dqn | {base} | {human(p)} {human_interval(low, high)} |" in text
    diff, low, high = stats.difference_ci(scores["dqn"], scores["default"], True, False, level=1 - 0.05 / 4)
    assert f"IQM dqn - default: {human(stats.snap(diff, scale))} {human_interval(low, high)}" in text
    assert "`p79` is identical to `p78` in every test episode" in text
    assert "every section tested at `v1.0-3-gabc1234`" in text and "Trained at code version `v1.0-3-gabc1234`" in text
    assert "gym4real reproduce gym4real/wds-v0 --budget paper --seeds 3 --out results/paper" in text
    claims = json.loads((tmp_path / "page" / "claims.json").read_text())
    spread = next(c for c in claims if c["relation"] == "less_variable")
    p79 = next(c for c in spread["comparisons"] if c["b"] == "p79")
    assert {"a", "b", "statistic", "estimate", "low", "high", "verdict", "rule"} <= set(p79)
    manifest = json.loads((tmp_path / "page" / "manifest.json").read_text())
    assert manifest["code_version"] == "v1.0-3-gabc1234" and manifest["data_files"]["wds-v0-paper"][0]["path"]


def test_sections_of_other_code_and_package_versions_show_every_version_and_none_as_the_pages(tmp_path: Path) -> None:
    """A re-published section (another commit, another domain version) does not hide behind the others' versions."""
    out = tmp_path / "out"
    _results_folder(out, "paper")
    other = _jax_section(out, "paper")
    report = json.loads((other / "report.json").read_text())
    report["code_version"], report["platform"] = "def5678", "Linux-other"
    report["versions"] = {"gym4real-core": "0.3.0", "mujoco": "4.0.0"}
    (other / "report.json").write_text(json.dumps(report))
    text = write_page(out, tmp_path / "page").read_text()
    line = next(x for x in text.splitlines() if x.startswith("Rendered by code version"))
    assert "sections tested at `def5678`, `v1.0-3-gabc1234` (each names its own)" in line
    assert "gym4real-core 0.2.0 / 0.3.0, mujoco 4.0.0;" in line and line.endswith("; Linux; Linux-other.")
    assert "most sections" not in text and "every section" not in line
    manifest = json.loads((tmp_path / "page" / "manifest.json").read_text())  # the line's source, as its twin
    assert manifest["versions"] == {"gym4real-core": "0.2.0 / 0.3.0", "mujoco": "4.0.0"}
    assert manifest["platform"] == "Linux; Linux-other"


def test_a_section_that_read_stand_in_data_says_so(tmp_path: Path) -> None:
    """A data file registered as a stand-in (trading's hourly bars) is named as one; the paper's own data is not."""
    stand_in = registry().datasets["trading/eurusd_1h_2017-2018"]
    assert stand_in.stand_in_for  # registered as a stand-in
    out = tmp_path / "out"
    folder = _results_folder(out, "paper")
    report = json.loads((folder / "report.json").read_text())
    report["data_files"] += [
        {"name": stand_in.name, "path": stand_in.path, "sha256": stand_in.sha256, "found": "GYM4REAL_DATA_DIR"},
        # absent at run time: microgrid trains on its synthetic stand-in then; wds has no stand-in
        {
            "name": "microgrid/demand/train",
            "path": "microgrid/demand/profiles_train.csv",
            "sha256": "1" * 64,
            "found": "no",
            "read_instead": {"path": "microgrid/demand/profiles_train_standin.csv", "sha256": "3" * 64, "found": "x"},
        },
        {"name": "wds/demand/catalogue", "path": "wds/demand/catalogue.csv", "sha256": "2" * 64, "found": "no"},
    ]
    (folder / "report.json").write_text(json.dumps(report))
    text = write_page(out, tmp_path / "page").read_text()
    line = next(line for line in text.splitlines() if line.startswith("Data: 4 files"))
    assert f"`{stand_in.name}` stands in for {stand_in.stand_in_for}" in line and "wds/network" not in line
    assert (
        "`microgrid/demand/train` was not found at run time: a preset that trains on it read the synthetic "
        "stand-in `microgrid/demand/profiles_train_standin.csv` instead (`gym4real data synthesize microgrid`; "
        f"SHA-256 `{'3' * 12}…` in `manifest.json`)" in line
    )
    manifest = json.loads((tmp_path / "page" / "manifest.json").read_text())
    read = next(r for r in manifest["data_files"]["wds-v0-paper"] if r["name"] == "microgrid/demand/train")
    assert read["read_instead"]["sha256"] == "3" * 64
    assert "`wds/demand/catalogue` was not found at run time." in line


def test_the_suite_score_of_each_paper_agent_is_recomputed_from_episodes_csv(tmp_path: Path) -> None:
    out = tmp_path / "out"
    folder = _results_folder(out, "paper")
    text = write_page(out, tmp_path / "page").read_text()
    scores, _ = _matrices(folder / "episodes.csv")
    random, best = stats.iqm(scores["random"]), stats.iqm(scores["default"])  # wds's best rule: `default`
    runs = [(stats.iqm(row) - random) / (best - random) for row in scores["dqn"]]
    expected = float(np.mean(runs))  # the IQM of three runs trims floor(0.25 * 3) = 0 of them at each end
    gap = float(np.mean([max(0.0, 1.0 - r) for r in runs]))
    per_env = (stats.iqm(scores["dqn"]) - random) / (best - random)  # all seeds' episodes pooled, normalised
    assert "Trained on `wds-v0`:" in text
    assert "| agent | runs | `wds-v0` | suite score (IQM) [95 % CI] | shortfall below the best rule [95 % CI] |" in text
    row = next(line for line in text.splitlines() if line.startswith("| dqn | 3 |"))
    assert row.startswith(f"| dqn | 3 | {human(per_env)} | {human(expected)} [") and f"| {human(gap)} [" in row
    assert "0 = random, 1 = `default`" in text and "optimality gap" not in text.replace("*optimality gap*", "")


def test_a_quick_budget_gives_no_suite_score(tmp_path: Path) -> None:
    _results_folder(tmp_path / "out", "quick")
    assert "## Suite score" not in write_page(tmp_path / "out", tmp_path / "page").read_text()


def test_the_page_folder_alone_regenerates_the_page(tmp_path: Path) -> None:
    out, page = tmp_path / "out", tmp_path / "page"
    _results_folder(out, "paper")
    first = write_page(out, page).read_text()
    assert "](wds-v0-paper/performance_profile.png)" in first
    assert (page / "wds-v0-paper" / "episodes.csv").exists() and (page / "wds-v0-paper" / "runs.csv").exists()
    assert write_page(page, page).read_text() == first


def test_quick_verdicts_are_pipeline_checks_and_stale_sections_are_flagged_whatever_their_commit(
    tmp_path: Path,
) -> None:
    from gym4real.results.fingerprints import KEY, fingerprints

    out = tmp_path / "out"
    paper = _results_folder(out, "paper")
    report = json.loads((paper / "report.json").read_text())
    report[KEY] = fingerprints("gym4real/wds-v0", "paper")  # current, though trained by another commit
    (paper / "report.json").write_text(json.dumps(report))
    # a second section (another env's folder name), from another code version, with no fingerprints
    _results_folder(tmp_path / "other", "quick", version="v0.9-dirty").rename(out / "zzz-v0-quick")
    text = write_page(out).read_text()
    quick = [line for line in _verdict_rows(text) if line.startswith("| `wds-v0`<br>quick |")]
    paper_rows = [line for line in _verdict_rows(text) if line.startswith("| `wds-v0` |")]  # a plain paper budget
    assert quick and all("pipeline check, not a verdict" in line and "**" not in line for line in quick)
    assert paper_rows and all("**" in line for line in paper_rows)
    assert "**Stale sections, flagged below: zzz-v0-quick.**" in text
    assert "**Stale** (`gym4real reproduce --check`): no fingerprints recorded." in text
    assert text.count("**Current**: its test protocol, data and trainer fingerprints equal") == 1


@pytest.mark.parametrize(
    ("text", "shown"),
    [
        ("missing in `/work/shared/data/microgrid/train.csv` (GYM4REAL_DATA_DIR)", "missing in `train.csv`"),
        ("cache ~/.cache/gym4real/dam/MEF.csv", "cache MEF.csv"),
        ("see https://example.org/a/b.csv", "see https://example.org/a/b.csv"),
    ],
)
def test_the_page_prints_no_machine_path(text: str, shown: str) -> None:
    from gym4real.results.results_page import no_paths

    assert no_paths(text).startswith(shown)


@pytest.mark.parametrize(
    ("value", "shown"),
    [
        (17170.4, "17,170"),
        (8087.3, "8,087"),
        (3850.6, "3,851"),
        (-1847.2, "-1,847"),
        (0.393512, "0.3935"),
        (-0.00233333, "-0.002333"),
        (-0.0, "0"),
        (1234567.0, "1,235,000"),
        (float("nan"), "-"),
        (2.912e-06, "0.000002912"),  # wds's forecast headroom end: no exponent beside the page's other numbers
        (-2.5e-05, "-0.000025"),
        (9.99996e-05, "0.0001"),
    ],
)
def test_numbers_are_written_for_people(value: float, shown: str) -> None:
    assert human(value) == shown
    assert human_interval(3850.6, 17170.4) == "[3,851, 17,170]"


def test_the_page_opens_with_the_verdicts_then_the_versions_and_the_summary_figure_and_ends_with_the_methods(
    tmp_path: Path,
) -> None:
    out = tmp_path / "out"
    _results_folder(out, "paper")
    text = write_page(out, tmp_path / "page").read_text()
    verdicts, versions = text.index("| env | paper's claim | verdict |"), text.index("Rendered by code version")
    figure, methods = text.index("](summary.png)"), text.index("## Methods")
    first_env = text.index("## `gym4real/wds-v0`")
    assert text.index("## Verdicts") < verdicts < versions < figure < first_env < methods
    assert text[text.index("![") :].split("\n", 1)[0].endswith("](summary.png)")  # the page's first figure
    assert (tmp_path / "page" / "summary.png").read_bytes()[:4] == b"\x89PNG"
    for word, mark in MARKS.items():  # each verdict word defined once, with its mark
        assert len(re.findall(rf"^- {mark} \*\*{word}\*\*: ", text, re.M)) == 1, word
    assert text.index("**Statistics.**") > methods and text.index("**Rules of the verdicts.**") > methods
    assert "does not hold" not in text


def test_the_verdict_table_is_narrow_each_verdict_has_its_mark_and_the_claim_in_full_lies_below(
    tmp_path: Path,
) -> None:
    """Issue 45: four short columns (a claim never squeezed to a word per line), a mark per verdict, details below."""
    out = tmp_path / "out"
    _results_folder(out, "paper")
    text = write_page(out, tmp_path / "page").read_text()
    # the paper's claims (the suite's own checks follow in a table of the same form)
    claims = [c for c in json.loads((tmp_path / "page" / "claims.json").read_text()) if c["paper"]]
    head = text.index("| env | paper's claim | verdict | deciding difference [interval] |\n|---|---|---|---|\n")
    paper = text[: text.index("Checks of this suite's own")] if "Checks of this suite's own" in text else text
    rows, details = _verdict_rows(paper), _verdict_details(paper)
    assert len(rows) == len(details) == len(claims) and text.index(rows[0]) > head
    below = text.index('<details markdown="1">')
    assert text.index(rows[-1]) < below < text.index(details[0]) < text.index("</details>")
    for claim, row, detail in zip(claims, rows, details, strict=True):
        cells = [cell.strip() for cell in row.strip("|").split("|")]
        assert len(cells) == 4
        assert cells[1] == claim["text"].split(" (")[0] and len(cells[1]) < len(claim["text"])  # the claim's own words
        assert cells[2].startswith(f"{MARKS[claim['verdict']]} **{claim['verdict']}**")
        assert max(len(cell) for cell in cells) <= 80, cells  # no cell long enough to squeeze the others
        assert detail.startswith(f"- `wds-v0`: {claim['text']}. Verdict: {MARKS[claim['verdict']]} ")
        assert "Rule: " in detail and "Deciding comparison: " in detail
    per_comparison = re.findall(r"\| (holds|refuted|inconclusive) \|", text)  # a section's claim table, per comparison
    assert not per_comparison and re.search(r"\| [✅❌❔] (holds|refuted|inconclusive) \|", text)


def test_the_page_writes_every_number_one_way_with_no_exponent(tmp_path: Path) -> None:
    """Issue 45: the headroom table wrote `-1.804e+04` beside `8,087`; every table now writes numbers as people do."""
    out = tmp_path / "out"
    folder = _results_folder(out, "paper")
    episodes = pd.read_csv(folder / "episodes.csv")
    episodes[["objective", "return", "dsr", "overflow"]] *= 1000.0  # scores in the tens of thousands
    upper = episodes[episodes["policy"] == "default"].assign(policy="hindsight")  # wds's upper reference
    upper["objective"] = upper["return"] = episodes["objective"].max() + 5000.0
    pd.concat([episodes, upper]).to_csv(folder / "episodes.csv", index=False)
    analyse(folder, "gym4real/wds-v0", "paper")
    text = write_page(out).read_text()
    headroom = text[text.index("## Headroom") :].split("\n## ", 1)[0]
    assert "| `wds-v0` | `hindsight` " in headroom and re.search(r"\d,\d{3}", headroom)
    words = re.sub(r"`[^`]*`", "", text)  # not in code: a commit hash such as `6e5f6c8` reads as an exponent
    assert not re.search(r"\d(\.\d+)?e[+-]?\d", words.replace("1e-6", "").replace("1e-9", "")), "an exponent"


def test_the_summary_figure_keeps_a_zero_width_interval_inside_its_axes() -> None:
    from gym4real.results import summary_figure

    summary = pd.DataFrame(
        [
            {"policy": "mine", "kind": "agent", "iqm": -0.286, "low": -0.286, "high": -0.286},  # a point interval
            {"policy": "random", "kind": "baseline", "iqm": 0.0, "low": -0.1, "high": 0.05},
            {"policy": "best", "kind": "baseline", "iqm": 1.0, "low": 1.0, "high": 1.0},
        ]
    )
    fig = summary_figure.figure([("gym4real/x-v0", "objective", summary)])
    ax = fig.axes[0]
    left, right = ax.get_xlim()
    assert left < summary[["low", "iqm"]].min().min() and right > summary[["high", "iqm"]].max().max()
    points = {round(float(line.get_xdata()[0]), 6) for line in ax.lines if len(line.get_xdata()) == 1}
    assert {-0.286, 0.0, 1.0} <= points  # every policy has its marker, the point interval's included
    bottom, top = ax.get_ylim()
    assert all(bottom < line.get_ydata()[0] < top for line in ax.lines)


def test_the_summary_figure_draws_the_upper_reference_apart_and_last() -> None:
    from gym4real.results import summary_figure

    summary = pd.DataFrame(
        [
            {"policy": "max", "kind": "baseline", "iqm": -5.0, "low": -6.0, "high": -4.0},
            {"policy": "ppo", "kind": "agent", "iqm": -3.0, "low": -3.5, "high": -2.5},
            {"policy": "hindsight", "kind": "baseline", "iqm": -1.0, "low": -1.2, "high": -0.8},  # as summary.csv says
            {"policy": "ead", "kind": "baseline", "iqm": -4.0, "low": -4.5, "high": -3.5},
        ]
    )
    fig = summary_figure.figure([("gym4real/dam-v0", "objective", summary)])
    ax = fig.axes[0]
    ticks = {round(float(y)): t.get_text() for y, t in zip(ax.get_yticks(), ax.get_yticklabels(), strict=True)}
    assert ticks[0] == label("gym4real/dam-v0", "hindsight")  # the bottom row, below the others
    assert ticks[0].startswith("hindsight (non-causal upper reference, heuristic")
    assert ticks[3] == "max" and ticks[2] == "ppo (agent)" and ticks[1] == "ead"
    points = {float(line.get_xdata()[0]): line for line in ax.lines if len(line.get_xdata()) == 1}
    upper = points[-1.0]
    assert upper.get_marker() == "*" and upper.get_color() == "black"
    assert upper.get_label() == "non-causal upper reference"
    assert all(line.get_marker() != "*" for x, line in points.items() if x != -1.0)
    assert [line for line in ax.lines if line.get_linestyle() == ":"]  # the rule above it
    assert "non-causal upper reference" in fig.get_suptitle()


def test_the_workspace_heatmap_counts_each_episodes_success_in_its_cell(tmp_path: Path) -> None:
    from gym4real.results.workspace import success_grid

    rng = np.random.default_rng(9)
    placements = pd.DataFrame({"episode": range(12), "u": rng.uniform(0, 100, 12), "v": rng.uniform(0, 50, 12)})
    rows = [
        {"policy": "ppo", "seed": s, "episode": e, "success": float(rng.random() < 0.5) * 0.5}
        for s in (0, 1)
        for e in range(12)
    ]
    episodes = pd.DataFrame(rows)
    edges = (np.array([0.0, 50.0, 100.0]), np.array([0.0, 25.0, 50.0]))
    rates, counts = success_grid(episodes, placements, "ppo", edges)
    for r in range(2):
        for c in range(2):
            inside = placements[
                (placements["u"] >= edges[0][c])
                & (placements["u"] < edges[0][c + 1])
                & (placements["v"] >= edges[1][r])
                & (placements["v"] < edges[1][r + 1])
            ]["episode"]
            mine = episodes[episodes["episode"].isin(inside)]
            assert counts[r, c] == len(mine)
            if len(mine):
                assert rates[r, c] == pytest.approx((mine["success"] > 0).mean())
    assert counts.sum() == 24


def test_the_published_claims_are_decided_from_the_published_episodes_under_the_current_rules() -> None:
    """Every verdict of ``docs/results`` re-decides from its ``episodes.csv``; the ones issues 32 and 38 changed."""
    from gym4real.results.analysis import check_claims
    from gym4real.results.artefacts import section_name, trainer_of

    page = ROOT / "docs" / "results"
    published = json.loads((page / "claims.json").read_text())
    for folder in sorted(p for p in page.iterdir() if (p / "episodes.csv").exists()):
        report = json.loads((folder / "report.json").read_text())
        episodes = pd.read_csv(folder / "episodes.csv")
        fresh = check_claims(report["env_id"], report["budget"], episodes, trainer_of(folder.name))
        assert fresh == json.loads((folder / "claims.json").read_text()), folder.name
        shown = [c for c in fresh if trainer_of(folder.name) == "sb3" or c["verdict"] != "not checked"]
        decided_here = [
            c for c in published if section_name(c["env_id"], c["budget"], c.get("trainer", "sb3")) == folder.name
        ]
        assert shown == decided_here, folder.name
    verdicts = {
        (c["env_id"].split("/")[1], c["policy"], c["relation"], c["others"][0] if len(c["others"]) == 1 else ""): c
        for c in ({**c, "others": [x["b"] for x in c["comparisons"]]} for c in published)
    }
    # 4 of 5 Q-learning seeds below longest_first by their IQMs, none by its own interval
    assert verdicts["elevator-v0", "qlearning", "above", ""]["verdict"] == "inconclusive"
    assert verdicts["elevator-v0", "sarsa", "above", ""]["verdict"] == "refuted"
    # PPO is buy-and-hold in every seed: "PPO consistently outperforms" is refuted, its negation holds
    assert verdicts["trading-v0", "ppo", "not_above", ""]["verdict"] == "holds"
    assert verdicts["trading-v0", "ppo", "less_variable", ""]["verdict"] == "refuted"
    picking = verdicts["robofeeder-picking-v0", "ppo", "above", "fixed"]
    assert (picking["quantity"], picking["statistic"], picking["paper"]) == ("success", "mean", True)
    # the difference of the shares of episodes whose object was picked, counted here from the episodes
    rows = pd.read_csv(page / "robofeeder-picking-v0-paper" / "episodes.csv")
    picked = (rows["success"] > 0).groupby(rows["policy"]).mean()
    assert picking["comparisons"][0]["estimate"] == pytest.approx(picked["ppo"] - picked["fixed"], abs=1e-12)
    assert picking["comparisons"][0]["low"] > 0 and picking["verdict"] == "holds"
    assert verdicts["robofeeder-picking-v1", "ppo", "above", "fixed"]["paper"] is False
    assert verdicts["dam-v0", "ppo", "above", ""]["others"] == ["random", "mean", "max", "ead"]
    # the suite's own MPC checks (issue 46): mpc scores above the agent on all three
    for env, agent in (("dam-v0", "ppo"), ("microgrid-v0", "ppo"), ("wds-v0", "dqn")):
        own = verdicts[env, agent, "above", "mpc"]
        assert own["paper"] is False and own["verdict"] == "refuted" and own["comparisons"][0]["high"] < 0, env
    assert {c["verdict"] for c in published} <= {"holds", "refuted", "inconclusive"}


def test_the_picking_v0_section_shows_the_success_heatmap_of_ppo_and_fixed() -> None:
    page = ROOT / "docs" / "results"
    folder = page / "robofeeder-picking-v0-paper"
    text = (page / "index.md").read_text(encoding="utf-8")
    section = text[
        text.index("## `gym4real/robofeeder-picking-v0`") : text.index("## `gym4real/robofeeder-picking-v1`")
    ]
    assert "](robofeeder-picking-v0-paper/success_heatmap.png)" in section
    placements = pd.read_csv(folder / "placements.csv")
    episodes = pd.read_csv(folder / "episodes.csv")
    assert placements["episode"].tolist() == sorted(episodes["episode"].unique())  # one position per test episode
    from gym4real.results.workspace import success_policies

    assert success_policies(folder) == ["ppo", "fixed"]


def test_a_published_section_is_decided_again_from_its_episodes_alone(tmp_path: Path) -> None:
    from gym4real.results.analysis import recheck

    out = tmp_path / "out"
    folder = _results_folder(out, "paper")
    before = json.loads((folder / "claims.json").read_text())
    (folder / "claims.json").write_text("[]")  # claims decided under other rules, or none
    assert recheck(folder) == before == json.loads((folder / "claims.json").read_text())


def test_stand_in_sections_are_marked_and_say_how_they_differ_from_the_paper() -> None:
    from gym4real.results.stand_ins import budget_mark, differences
    from gym4real.rl.presets import load_preset

    results = ROOT / "docs" / "results"
    trading = json.loads((results / "trading-v0-paper" / "report.json").read_text())
    microgrid = json.loads((results / "microgrid-v0-paper" / "report.json").read_text())
    dam = json.loads((results / "dam-v0-paper" / "report.json").read_text())
    assert budget_mark(trading, "paper") == (
        "paper (**stand-in data**: EUR/USD hourly ask OHLCV; EUR/USD hourly OHLCV; **2.6 % of the paper's steps**)"
    )
    assert budget_mark(microgrid, "paper") == "paper (**stand-in data**: synthetic `microgrid/demand/train`)"
    assert budget_mark(dam, "paper") == "paper"  # the paper's own data
    found = differences(trading, pd.read_csv(results / "trading-v0-paper" / "episodes.csv"))
    steps = load_preset("gym4real/trading-v0", "ppo", "hourly")["total_timesteps"]
    paper = load_preset("gym4real/trading-v0", "ppo", "paper")["total_timesteps"]
    assert f"{100 * steps / paper:.1f} % of the {paper:,} of `ppo/paper`" in "; ".join(found)
    assert found[0].startswith("data: EUR/USD hourly") and found[-1].startswith("test: 68 episodes")
    assert differences(dam, pd.read_csv(results / "dam-v0-paper" / "episodes.csv")) == []


def test_no_published_row_beats_an_upper_reference_called_a_bound() -> None:
    """Every section: per test episode, no policy's seed scores above an upper reference its domain calls a bound:
    an exact one to float noise, a heuristic one by at most its declared gap (issue 44)."""
    from gym4real.core.registry import non_causal, upper_reference

    checked = set()
    for folder in sorted((ROOT / "docs" / "results").glob("*/episodes.csv")):
        episodes = pd.read_csv(folder)
        env_id = json.loads((folder.parent / "report.json").read_text())["env_id"]
        for name in non_causal(env_id):
            spec = upper_reference(env_id, name)
            if not spec.is_bound or name not in set(episodes["policy"]):
                continue
            upper = episodes[episodes["policy"] == name].set_index("episode")["objective"]
            others = episodes[episodes["policy"] != name]
            assert len(upper) == others["episode"].nunique(), folder.parent.name  # every test episode
            best = others.groupby("episode")["objective"].max()
            allowed = upper.abs() * (spec.gap or 0.0) + 1e-9 * upper.abs().clip(lower=1)
            beaten = best[best > upper.reindex(best.index) + allowed.reindex(best.index)]
            assert beaten.empty, (folder.parent.name, name, beaten.to_dict())
            checked.add((env_id, spec.bound))
    assert {e for e, _ in checked} >= {f"gym4real/{d}-v0" for d in ("dam", "elevator", "microgrid", "trading", "wds")}
    assert ("gym4real/trading-v0", "exact") in checked and ("gym4real/dam-v0", "heuristic") in checked


def test_planning_v0_s_oracle_is_beaten_and_called_no_bound_in_the_headroom_table() -> None:
    """PPO scores above the oracle on some planning-v0 episodes: the oracle is `not a bound`, with no headroom."""
    episodes = pd.read_csv(ROOT / "docs" / "results" / "robofeeder-planning-v0-paper" / "episodes.csv")
    oracle = episodes[episodes["policy"] == "oracle"].set_index("episode")["objective"]
    ppo = episodes[episodes["policy"] == "ppo"]
    assert (ppo["objective"].to_numpy() > oracle.reindex(ppo["episode"]).to_numpy()).any()
    text = (ROOT / "docs" / "results" / "index.md").read_text(encoding="utf-8")
    table = text[text.index("## Headroom") :].split("\n## ", 1)[0]
    rows = [line for line in table.splitlines() if line.startswith("| `robofeeder-planning-v0` |")]
    assert rows and all("| not a bound |" in line and "- (not a bound)" in line for line in rows)
    lines = table.splitlines()[table.splitlines().index(HEADROOM_HEADER) + 2 :]
    for line in lines[: next((i for i, line in enumerate(lines) if not line.startswith("|")), len(lines))]:
        if line.startswith("| `"):  # an env's first row (its other agents' rows leave the env and kind empty)
            assert re.search(r"\| (exact|heuristic \(a further search gains <= [0-9.]+ %\)|not a bound) \|", line)


def test_a_verdict_about_an_agent_that_plays_a_baseline_says_so_with_its_share_of_the_paper_budget() -> None:
    """Trading's PPO keeps its first checkpoint in every seed and scores as Buy&Hold on every test day."""
    text = (ROOT / "docs" / "results" / "index.md").read_text(encoding="utf-8")
    rows = [line for line in _verdict_rows(text) if line.startswith("| `trading-v0`<br>paper, stand-in |")]
    details = [line for line in _verdict_details(text) if line.startswith("- `trading-v0`: ")]
    assert len(rows) == len(details) == 4
    ppo = [line for line in rows if "| PPO " in line]
    assert len(ppo) == 2 and all("`ppo` scores as `buy_and_hold`" in line for line in ppo)
    assert not any("scores as" in line for line in rows if "| DQN " in line)
    ppo = [line for line in details if ": PPO " in line]
    assert len(ppo) == 2 and all(
        "`ppo` learned nothing beyond `buy_and_hold`: every seed scores exactly as `buy_and_hold`" in line
        for line in ppo
    )
    assert not any("learned nothing" in line for line in details if ": DQN " in line)
    assert all("**2.6 % of the paper's steps**" in line for line in details)


def test_verdicts_carry_the_cross_machine_caveat_while_the_section_records_one(tmp_path: Path) -> None:
    # the published sections: robofeeder's re-published rows are the same under every dispatch setting
    # (docs/robofeeder-determinism.md), so no section records a caveat and no verdict shows one
    page = ROOT / "docs" / "results"
    recorded = [p.name for p in page.glob("*/report.json") if "machine_dependent" in json.loads(p.read_text())]
    text = (page / "index.md").read_text(encoding="utf-8")
    lines = _verdict_rows(text) + _verdict_details(text)
    assert recorded == [] and lines and not any("machine-dependent" in line or "**caveat**" in line for line in lines)
    out = tmp_path / "out"
    folder = _results_folder(out, "paper")
    report = json.loads((folder / "report.json").read_text())
    report["machine_dependent"] = "rerun on another machine, 3 of random's 20 test episodes score differently"
    (folder / "report.json").write_text(json.dumps(report))
    text = write_page(out).read_text()
    rows, details = _verdict_rows(text), _verdict_details(text)
    assert rows and all(line.endswith("|") and "<br>machine-dependent |" in line for line in rows)
    assert all("(rerun on another machine, 3 of random's 20 test episodes" in line for line in details)
    del report["machine_dependent"]  # a rerun found every row equal on another machine: the data lifts the caveat
    (folder / "report.json").write_text(json.dumps(report))
    text = write_page(out).read_text()
    lines = _verdict_rows(text) + _verdict_details(text)
    assert lines and not any("machine-dependent" in line or "caveat" in line for line in lines)


def _deciding_end(comparison: dict) -> float:
    """The end of a comparison's interval nearest 0: the one whose crossing would change its verdict."""
    return min(comparison["low"], comparison["high"], key=abs)


@pytest.mark.slow
def test_rerunning_the_analysis_with_five_bootstrap_seeds_changes_no_verdict_and_hardly_moves_a_deciding_end() -> None:
    """Issue 44: the replicates grow with the level, so the published verdicts do not rest on the bootstrap's seed."""
    from gym4real.results.analysis import check_claims
    from gym4real.results.artefacts import trainer_of

    def words(claim: dict) -> list:
        found = [claim["verdict"], claim.get("margin_reading", {}).get("verdict")]
        for c in claim["comparisons"]:
            found += [c["verdict"], c.get("margin_verdict"), *(s["verdict"] for s in c.get("seeds", []))]
        return found

    for folder in sorted((ROOT / "docs" / "results").glob("*-paper*")):
        report = json.loads((folder / "report.json").read_text())
        episodes = pd.read_csv(folder / "episodes.csv")
        trainer = trainer_of(folder.name)
        runs = [check_claims(report["env_id"], "paper", episodes, trainer, bootstrap_seed=seed) for seed in range(5)]
        for claims in zip(*runs, strict=True):
            assert all(words(c) == words(claims[0]) for c in claims), (folder.name, claims[0]["text"])
            deciding = [next(x for x in c["comparisons"] if x["b"] == c["deciding"]) for c in claims]
            ends = [_deciding_end(x) for x in deciding]
            width = float(np.mean([x["high"] - x["low"] for x in deciding]))
            assert max(ends) - min(ends) <= 0.05 * width, (folder.name, claims[0]["text"], ends, width)


def test_the_page_shows_mpc_the_suites_mpc_check_and_the_headroom_split(tmp_path: Path) -> None:
    """A wds section with `mpc` and `hindsight` rows: mpc's row, DQN-beats-MPC decided apart, both headrooms."""
    from gym4real.bench.upper_reference import headroom_split
    from gym4real.results.headroom_page import SPLIT_HEADER

    out = tmp_path / "out"
    folder = _results_folder(out, "paper")
    episodes = pd.read_csv(folder / "episodes.csv")
    best = episodes.groupby("episode")["objective"].max().to_numpy()
    mpc = np.minimum(np.random.default_rng(1).normal(165, 2, 20), best + 0.5)
    rows = [
        {"policy": name, "seed": None, "episode": i, "objective": v, "return": v, "dsr": v + 50.0, "overflow": -50.0}
        for name, values in (("mpc", mpc), ("hindsight", np.maximum(best, mpc) + 1.0))
        for i, v in enumerate(values)
    ]
    episodes = pd.concat([episodes, pd.DataFrame(rows)], ignore_index=True)
    episodes["seed"] = episodes["seed"].astype("Int64")
    episodes.to_csv(folder / "episodes.csv", index=False)
    analyse(folder, "gym4real/wds-v0", "paper")
    report = json.loads((folder / "report.json").read_text())
    command = "python scripts/add_upper_references.py --policies mpc docs/results/wds-v0-paper"
    record = {"policies": ["mpc"], "code_version": "abc1234", "command": command, "test_wall_time_s": 342.0}
    (folder / "report.json").write_text(json.dumps({**report, "added_baselines": [record]}))
    text = write_page(out, tmp_path / "page").read_text()
    assert (
        f"Measured later, on the same test protocol: baselines `mpc` at code version `abc1234` (`{command}`, test "
        "5.7 min); the other rows are this section's own." in text
    )
    scores, _ = _matrices(folder / "episodes.csv")
    iqm, low, high = stats.iqm_ci(scores["mpc"], False)
    assert f"| mpc | - | 20 | {human(iqm)} | {human_interval(low, high)} |" in text  # the section's row
    check = next(c for c in json.loads((folder / "claims.json").read_text()) if c["deciding"] == "mpc")
    assert check["paper"] is False and check["verdict"] == "refuted"  # mpc ~165, DQN's seeds 150, 60, 158
    own = text[text.index("Checks of this suite's own") : text.index("The verdicts (each with")]
    assert "| `wds-v0` | DQN achieves a higher resilience than model-predictive control |" in own
    assert "| ❌ **refuted** |" in own and "IQM dqn - mpc: " in own
    paper = text[text.index("## Verdicts on the paper's claims") : text.index("Checks of this suite's own")]
    assert "model-predictive" not in paper
    section = text[text.index("## `gym4real/wds-v0`") :]
    assert section.index("Claims of the paper:") < section.index("IQM dqn - mpc: ")
    assert section.index("This suite's own checks") < section.index("IQM dqn - mpc: ")
    split = headroom_split(scores["hindsight"], scores["mpc"], scores["dqn"])
    assert split["learning"]["shortfall"] > 0
    table = text[text.index("### Forecast and learning headroom") :].split("\n## ", 1)[0]
    assert SPLIT_HEADER in table and "the agent's training seeds as well" in table
    cells = [f"{human(split[k]['shortfall'])} {human_interval(split[k]['low'], split[k]['high'])}" for k in split]
    assert f"| `dqn` {human(stats.iqm(scores['dqn']))} | {cells[0]} | {cells[1]} |" in table


def test_an_agent_at_or_above_mpc_has_no_learning_headroom() -> None:
    from gym4real.results.headroom_page import split_rows

    mpc = np.linspace(0.0, 19.0, 20)
    scores = {"hindsight": mpc[None] + 3.0, "mpc": mpc[None], "ppo": np.vstack([mpc + 1.0, mpc + 2.0])}
    (row,) = split_rows("dam-v0", "hindsight", scores, ["ppo"])
    assert "| `ppo` 11 | 3 [3, 3] | none: `ppo` scores at least `mpc` (`mpc` - agent -1.5 [-2, -1]) |" in row
    assert split_rows("dam-v0", "hindsight", {k: v for k, v in scores.items() if k != "mpc"}, ["ppo"]) == []


def test_the_committed_pages_tables_write_no_number_with_an_exponent() -> None:
    """Issue 45's one number format in the published page's tables too (wds's forecast headroom read `2.912e-06`;
    the prose keeps its recorded sentences, such as a float-noise difference of 2.84e-14)."""
    text = (ROOT / "docs" / "results" / "index.md").read_text(encoding="utf-8")
    rows = [re.sub(r"`[^`]*`", "", line) for line in text.splitlines() if line.startswith("|")]  # code spans aside
    assert len(rows) > 100 and not [row for row in rows if re.search(r"\d(\.\d+)?e[+-]?\d", row)]
