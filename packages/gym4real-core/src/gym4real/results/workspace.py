"""Success over the workspace: where each test episode's object lay, and each policy's success rate there.

A protocol with ``BenchmarkSpec.placements`` says where its object lies in each test episode (camera-image
pixels, read by resetting the env with the episode's seed). :func:`write_placements` writes them as
``placements.csv`` beside ``episodes.csv``; :func:`heatmap_figure` bins the episodes over the workspace and
draws, per policy of the section's success claims, the fraction of its test episodes that succeeded in
each cell (an RL algorithm's seeds pooled), from those two files alone.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from gym4real.core.errors import ConfigError

#: The file of the episodes' object positions, and the figure drawn from it.
PLACEMENTS = "placements.csv"
HEATMAP = "success_heatmap.png"
#: Cells of the heat map along each image axis.
BINS = 4


def write_placements(folder: Path, env_id: str) -> Path | None:
    """``folder/placements.csv`` (``episode, u, v``) from the protocol's ``placements`` hook; None without one."""
    from gym4real.bench.benchmark import protocol
    from gym4real.core.registry import load_object

    spec = protocol(env_id)
    if spec.placements is None:
        return None
    positions = load_object(spec.placements)(dict(spec.env_kwargs))
    frame = pd.DataFrame(positions, columns=["u", "v"]).rename_axis("episode").reset_index()
    frame.to_csv(folder / PLACEMENTS, index=False)
    return folder / PLACEMENTS


def success_grid(
    episodes: pd.DataFrame, placements: pd.DataFrame, policy: str, edges: tuple[np.ndarray, np.ndarray]
) -> tuple[np.ndarray, np.ndarray]:
    """Per cell (rows: image v, columns: image u): ``policy``'s success rate and its number of episodes.

    An episode succeeds when its ``success`` reward component is positive; the rate of a cell is over every
    run (seed) and episode whose object lay in it (NaN for a cell with none).
    """
    missing = sorted({"episode", "u", "v"} - set(placements.columns))
    if missing:
        raise ConfigError(f"`{PLACEMENTS}` has no column {missing}; write it with `episode, u, v`")
    rows = episodes[episodes["policy"] == policy].merge(placements, on="episode", how="left")
    if rows[["u", "v"]].isna().any().any():
        raise ConfigError(f"`{PLACEMENTS}` lacks a position of some test episode of `{policy}`; write it again")
    won = (rows["success"] > 0).to_numpy(float)
    total, _, _ = np.histogram2d(rows["v"], rows["u"], bins=edges[::-1])
    wins, _, _ = np.histogram2d(rows["v"], rows["u"], bins=edges[::-1], weights=won)
    with np.errstate(invalid="ignore", divide="ignore"):
        rates = np.where(total > 0, wins / np.maximum(total, 1), np.nan)
    return rates, total.astype(int)


def success_policies(folder: Path) -> list[str]:
    """The policies of the section's success claims (``claims.json``): the claim's policy, then the others."""
    claims = json.loads((folder / "claims.json").read_text()) if (folder / "claims.json").exists() else []
    found: list[str] = []
    for claim in claims:
        if claim.get("quantity") == "success":
            found += [p for p in (claim["policy"], *(c["b"] for c in claim["comparisons"])) if p not in found]
    return found


def heatmap_figure(folder: Path, title: str) -> Path | None:
    """``folder/success_heatmap.png``: per policy of the success claims, its success rate per workspace cell.

    None (and no file) when the folder has no ``placements.csv`` or no success claim.
    """
    if not (folder / PLACEMENTS).exists():
        return None
    policies = success_policies(folder)
    if not policies:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    episodes, placements = pd.read_csv(folder / "episodes.csv"), pd.read_csv(folder / PLACEMENTS)
    u, v = placements["u"].to_numpy(float), placements["v"].to_numpy(float)
    edges = (
        np.linspace(np.floor(u.min()), np.ceil(u.max()), BINS + 1),
        np.linspace(np.floor(v.min()), np.ceil(v.max()), BINS + 1),
    )
    fig, axes = plt.subplots(1, len(policies), figsize=(4.2 * len(policies), 4.2), squeeze=False, layout="constrained")
    image = None
    for ax, policy in zip(axes[0], policies, strict=True):
        rates, counts = success_grid(episodes, placements, policy, edges)
        runs = episodes.loc[episodes["policy"] == policy, "seed"].nunique() or 1
        extent = (edges[0][0], edges[0][-1], edges[1][-1], edges[1][0])
        image = ax.imshow(np.ma.masked_invalid(rates), extent=extent, cmap="viridis", vmin=0, vmax=1, aspect="auto")
        for r in range(BINS):
            for c in range(BINS):
                if counts[r, c]:
                    x = (edges[0][c] + edges[0][c + 1]) / 2
                    y = (edges[1][r] + edges[1][r + 1]) / 2
                    ax.text(
                        x, y, f"{rates[r, c]:.2f}\n(n={counts[r, c]})", ha="center", va="center", fontsize=7, color="w"
                    )
        total = float((episodes.loc[episodes["policy"] == policy, "success"] > 0).mean())
        seeds = f", {runs} seeds pooled" if runs > 1 else ""
        ax.set(xlabel="image u (px)", ylabel="image v (px)" if ax is axes[0][0] else "")
        ax.set_title(f"{policy}: success rate {total:.2f}{seeds}")
        ax.title.set_fontsize(9)
    if image is not None:
        fig.colorbar(image, ax=axes[0].tolist(), label="success rate", shrink=0.8)
    fig.suptitle(
        f"{title}: success rate over the workspace\n({len(placements)} test episodes in {BINS} x {BINS} cells; "
        "n: episodes x seeds in a cell)",
        fontsize=10,
    )
    path = folder / HEATMAP
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
