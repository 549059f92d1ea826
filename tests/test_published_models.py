"""The models published with the results page rerun their seed's published test episodes exactly.

``docs/results/<env>-<budget>/models/`` holds every trained model up to 5 MB, listed with its SHA-256 in
``models.json`` and the manifest; ``gym4real evaluate`` on one of them must score, episode by episode, what
that seed's rows of ``episodes.csv`` record (the CSV round-trips floats).
"""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pytest

from gym4real.results.published_models import MAX_BYTES, sha256_of

RESULTS = Path(__file__).parents[1] / "docs" / "results"


@pytest.mark.parametrize(
    ("section", "algo", "seed"), [("dam-v0-paper", "ppo", 0), ("dam-v0-paper", "ppo", 123), ("wds-v0-paper", "dqn", 42)]
)
def test_evaluating_a_published_model_reproduces_its_published_test_episodes(
    section: str, algo: str, seed: int
) -> None:
    pytest.importorskip("stable_baselines3")
    from gym4real.bench.evaluate import evaluate

    folder = RESULTS / section
    report = json.loads((folder / "report.json").read_text())
    model = next(m for m in json.loads((folder / "models.json").read_text()) if (m["algo"], m["seed"]) == (algo, seed))
    assert model["published"] and model["bytes"] <= MAX_BYTES
    for file in model["files"]:
        assert sha256_of(folder / Path(model["path"]).parent / file["name"]) == file["sha256"], file["name"]
    result = evaluate({"published": f"{algo}:{folder / model['path']}"}, [report["env_id"]], seeds=[seed])
    mine = result.envs[report["env_id"]].episodes.sort_values("episode").reset_index(drop=True)
    published = pd.read_csv(folder / "episodes.csv")
    theirs = published[(published["policy"] == algo) & (published["seed"] == seed)].sort_values("episode")
    assert len(theirs) == len(mine) > 0
    for column in ("objective", "return"):
        assert mine[column].tolist() == theirs[column].tolist(), column


def test_every_published_model_is_listed_with_its_hash_in_the_manifest() -> None:
    manifest = json.loads((RESULTS / "manifest.json").read_text())
    for listing in sorted(RESULTS.glob("*-paper/models.json")):
        section = listing.parent.name
        files = manifest["provenance"][section]["files"]
        for model in json.loads(listing.read_text()):
            if model["published"]:
                for file in model["files"]:
                    relative = f"{section}/{Path(model['path']).parent.as_posix()}/{file['name']}"
                    assert files[relative] == file["sha256"] == sha256_of(RESULTS / relative), relative
            else:  # too large to publish (its hash), or not kept: the command that trains it again
                assert model["files"] == "not recorded" or model["bytes"] > MAX_BYTES, (section, model["seed"])
                assert model["retrain"].startswith(f"gym4real train {manifest['provenance'][section]['env_id']} ")
