"""TradingEnv: intraday EUR/USD trading, one trading day per episode."""

from __future__ import annotations

import datetime as dt
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from gym4real.core.actions import DiscreteAction
from gym4real.core.perturbation import check_scales
from gym4real.trading import features
from gym4real.trading.config import TradingConfig

SHORT, FLAT, LONG = 0, 1, 2
ACTIONS = "0 (short), 1 (flat) or 2 (long)"


class TradingEnv(gym.Env[np.ndarray, Any]):
    """Intraday trading of one currency pair on historical mid prices (Gym4ReaL ``TradingEnv``).

    ## Description
    One episode is one trading day of the configured split, from ``trading_open`` to
    ``trading_close`` (market time: EST without daylight saving). Every ``persistence`` minutes the
    agent takes a short, flat or long position of a fixed notional ``capital`` in EUR; the position is
    forced flat at the end of the day. Prices are mid prices on a bar grid (``bar_minutes``) built from
    HistData tick or 1-minute files, or from any CSV of quotes (see :mod:`gym4real.trading.quotes` and
    :mod:`gym4real.trading.processing`). The packaged ``default``/``train``/``validation``/``test``
    presets run on the two real hourly EUR/USD files of the data folder; the ``paper_*`` presets are
    the paper's 1-minute HistData setting (2019-2022, which users fetch).

    ## Action Space
    ``Discrete(3)``: 0 short, 1 flat, 2 long; position = action - 1. Anything else (a NaN, 3, a
    non-integer) raises ``ValueError``.

    ## Observation Space
    ``Box(-inf, inf, (n,))``, float32 (float64 with ``fidelity="upstream"``): the ``number_of_deltas``
    relative mid-price changes (min-max scaled with the train split's range when ``normalize``), then
    the optional month / day of month / weekday (sin-cos with ``sinusoidal_transformation``), the time
    of day (sin and cos of 2 pi times the fraction of the session, or the fraction itself), then the
    position as the action code (0, 1, 2). ``n = 63`` with the paper's settings. Column names:
    ``env.unwrapped.feature_names``.

    ## Rewards
    ``capital * position * (p[t+1] - p[t]) - fees * |position - previous position|`` (USD: P&L of the
    new position over the holding interval minus one fee per unit of position change); the last step
    also pays ``fees * |position|`` for the forced close. ``info["reward_components"]``: ``pnl`` and
    ``fees`` (negative). ``info["cost"]`` is 0.0: the reference has no constraint (no drawdown limit).
    ``info`` also holds ``pnl``, ``fees`` (positive), ``position`` (held over the step, -1/0/1),
    ``mid_price`` and ``timestamp`` at the end of the step, ``cum_pnl`` and ``cum_fees`` (the
    reference's only key is ``datetime``). ``timestamp`` is the label of the price's bar, i.e. its
    start (market time, ``numpy.datetime64``); the bar's price is its last quote, as in the reference.

    ## Starting State
    Flat at the session's first bar of a day: ``reset(seed=s)`` draws a day of the split with
    ``self.np_random``; ``options={"day": "YYYY-MM-DD"}`` (or a date, or an index into
    ``env.unwrapped.days``) selects one. With ``sequential``, ``reset(seed=s)`` takes day ``s`` modulo
    the number of days and ``reset()`` the next day, so consecutive seeds walk the split in order.
    :func:`gym4real.trading.evaluation.test_episodes` lists every day of a split.

    ## Episode End
    Truncated at the close, after ``(session_bars - 1) // p`` decisions (p = persistence in bars): 119
    with 1-minute bars over 08:00-18:00 and p = 5, the last one held 17:50-17:55; 7 with the hourly
    presets (08:00-16:00). Never terminated.

    ## Arguments
    ``gymnasium.make("gym4real/trading-v0", config=None, preset=None, render_mode=None, **overrides)``:
    ``config`` is a :class:`TradingConfig`, a mapping or a YAML path; ``preset`` one of ``default``,
    ``train``, ``validation``, ``test``, ``paper_train``, ``paper_validation``, ``paper_test``,
    ``paper_benchmark``; overrides are config fields (``fidelity="upstream"``, ``split="test"``, ...).
    Perturbable parameters (:meth:`perturb`, both modes): ``price_shock`` (the day's price moves around
    its opening price, for P&L and observation alike) and ``fees``. The batched
    :class:`~gym4real.trading.vector.TradingVectorEnv` has no ``perturb`` and always trades the nominal
    prices and fee.

    ## Corrected mode and ``fidelity="upstream"``
    The default mode fixes the reference's defects; ``fidelity="upstream"`` restores those that change
    numbers, each also switchable alone in ``fixes``:

    1. ``close_fee_on_new_position``: the forced-close fee is charged on the position just taken;
       upstream charges the previous position (a position closed at the last step pays twice, one
       opened then pays nothing for its close).
    2. ``full_session``: decisions until the last full holding interval; upstream stops when fewer
       than two intervals remain (118 decisions, the last held 17:45-17:50, and the final observation
       is the row one interval later).
    3. ``continuous_features``: changes and forward fill on the continuous series; upstream along the
       concatenated sessions, so overnight and weekend moves appear as one-bar changes at the open and
       the previous close fills the first minutes.
    4. ``truncate_at_close``: the close is a time limit (truncated); upstream sets terminated too.
    5. ``calendar_encoding``: calendar features as sin-cos; upstream raw values (its sin-cos branch is
       unreachable, and its weekday column does not exist: here the raw weekday).
    6. ``float32_observations``: float32; upstream float64.

    In both modes: Gymnasium's ``reset(seed=, options=)`` and ``self.np_random`` (the reference takes
    ``day_to_set`` first and seeds the global NumPy generator); the env is registered on import and
    built from packaged presets; the scaler is fitted on the train split and re-implemented (no
    scikit-learn; ``get_scaler()`` has ``data_min_``/``data_max_``); HistData files are matched by
    name and the cache lives outside the data folder; day lookups and the observation matrix of a day
    are precomputed at reset (a step is a few list lookups).

    ## Version History
    * v0: Gym4ReaL v1.0 TradingEnv, corrected by default.
    """

    metadata: dict[str, Any] = {"render_modes": ["ansi", "rgb_array"], "render_fps": 4}
    #: Keys of ``info["reward_components"]``, in order (their sum is the reward).
    reward_component_names = ("pnl", "fees")
    perturbable: tuple[str, ...] = ("price_shock", "fees")

    def __init__(
        self,
        config: TradingConfig | Mapping[str, Any] | str | Path | None = None,
        *,
        preset: str | None = None,
        render_mode: str | None = None,
        **overrides: Any,
    ) -> None:
        self.config = cfg = TradingConfig.build(config, preset, **overrides)
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']} or None, not {render_mode!r}")
        self.render_mode = render_mode
        self.data = features.split_data(cfg)
        self._dtype = np.float32 if cfg.fix("float32_observations") else np.float64
        self._features = features.feature_matrix(cfg, self.data, self._dtype)
        self.feature_names = features.feature_names(cfg)
        self.days: list[dt.date] = list(self.data.days)
        self._day_of = {d: i for i, d in enumerate(self.days)}
        n_bars = cfg.session_bars
        p = cfg.persistence // cfg.bar_minutes
        if cfg.fix("full_session"):
            self.n_steps = (n_bars - 1) // p
            final_row = self.n_steps * p
        else:  # the reference: stop when the row two intervals ahead leaves the day
            self.n_steps = -(-n_bars // p) - 2
            final_row = (self.n_steps + 1) * p
        self._obs_rows = np.r_[np.arange(self.n_steps) * p, final_row]
        self._price_rows = np.arange(self.n_steps + 1) * p
        self._cap, self._fee = float(cfg.capital), float(cfg.fees)  # nominal (TradingVectorEnv reads them)
        self._scales = dict.fromkeys(self.perturbable, 1.0)
        self._off = cfg.offset // cfg.bar_minutes
        self._close_new = cfg.fix("close_fee_on_new_position")
        self._terminate = not cfg.fix("truncate_at_close")
        dim = self._features.shape[2] + 1
        self.action_space = spaces.Discrete(3)
        self._action = DiscreteAction(self.action_space, ACTIONS)
        self.observation_space = spaces.Box(-np.inf, np.inf, (dim,), self._dtype)
        self._day = -1
        self._load_day(0)

    # -- data ----------------------------------------------------------------------------------------

    def get_scaler(self) -> features.MinMaxScaler | None:
        """The min-max scaler of the changes (fitted on the train split), or None without normalisation."""
        return features.scaler(self.config) if self.config.normalize else None

    def data_report(self) -> dict[str, Any]:
        """Kept and dropped days of the split, with the reasons."""
        return self.data.report()

    def _load_day(self, index: int) -> None:
        self._day = index
        mid = self.data.mid[index]
        shock = self._scales["price_shock"]
        if shock == 1.0:
            rows = self._features[index, self._obs_rows]
        else:
            mid = mid[0] + shock * (mid - mid[0])
            if mid.min() <= 0:
                msg = f"`price_shock` {shock:g} drives the price of {self.days[index]} to {mid.min():.6g} <= 0"
                raise ValueError(msg + "; use a smaller scale")
            rows = self._shocked_features(index, mid)[self._obs_rows]
        self._episode_fee = self._fee * self._scales["fees"]
        obs = np.empty((3, len(rows), rows.shape[1] + 1), dtype=self._dtype)
        obs[:, :, :-1] = rows
        obs[:, :, -1] = np.arange(3)[:, None]
        obs.flags.writeable = False  # rows are returned as views: keep them immutable
        self._obs = (obs[0], obs[1], obs[2])
        self._mid = mid[self._price_rows].tolist()
        self._time = list(self.data.time[index, self._price_rows])
        self._k = 0
        self._pos = 0
        self._positions = [0] * self.n_steps
        self.cum_pnl = 0.0
        self.cum_fees = 0.0

    def _shocked_features(self, index: int, shocked: np.ndarray) -> np.ndarray:
        """The day's feature rows with the price changes recomputed on the shocked session prices.

        Change ``d = p(a) / p(b) - 1`` (``b = a - offset``): recomputed when both bars are in the session;
        kept when both precede the open (the history is not shocked); across the open, ``p(b)`` is the
        historical price ``p(a) / (1 + d)``, so ``d' = (1 + d) p'(a) / p(a) - 1`` (a change stored as 0,
        missing data or no move, stays 0; with ``offset`` one bar, ``p'(a) = p(a)`` at the open).
        """
        cfg, nominal = self.config, self.data.mid[index]
        deltas = self.data.deltas[index].copy()  # (bars, number_of_deltas)
        a = np.arange(len(nominal))[:, None] - np.arange(cfg.number_of_deltas)[None, :] * self._off
        b = a - self._off
        inside = b >= 0
        deltas[inside] = shocked[a[inside]] / shocked[b[inside]] - 1.0
        across = (a > 0) & (b < 0) & (deltas != 0.0)
        deltas[across] = (1.0 + deltas[across]) * shocked[a[across]] / nominal[a[across]] - 1.0
        if cfg.normalize:
            deltas = features.scaler(cfg).transform(deltas)
        rows = self._features[index].copy()
        rows[:, : cfg.number_of_deltas] = deltas
        return rows

    # -- exogenous perturbation ----------------------------------------------------------------------

    def perturb(self, scales: Mapping[str, float]) -> None:
        """Scale market parameters from the next ``reset()`` on, until the next call.

        Scales multiply the configured (nominal) values, never the current ones: a call replaces the
        previous one, and ``perturb({})`` restores the nominal market.

        Args:
            scales: Multipliers by name (missing names are 1). ``price_shock`` s moves every session price
                of the day away from the day's first price p0: ``p'(t) = p0 + s (p(t) - p0)``, used for the
                P&L, ``info["mid_price"]`` and the observed price changes (history before the open is
                kept), so holding a position over any interval earns s times its nominal P&L. ``fees``
                multiplies the fee per unit of position change.

        Raises:
            ValueError: A name not in ``perturbable``, or a scale that is not a finite positive number.
        """
        self._scales = check_scales(scales, self.perturbable)

    def _day_index(self, day: Any) -> int:
        if isinstance(day, (int, np.integer)) and not isinstance(day, bool):
            if not -len(self.days) <= int(day) < len(self.days):
                raise ValueError(f"day index {day} out of range: the split has {len(self.days)} days")
            return int(day) % len(self.days)
        try:
            date = np.datetime64(day, "D").astype(object) if not isinstance(day, dt.date) else day
            if isinstance(date, dt.datetime):
                date = date.date()
        except (ValueError, TypeError) as exc:
            raise ValueError(f"`options['day']` must be a date, `YYYY-MM-DD` or an index, not {day!r}") from exc
        if date not in self._day_of:
            why = self.data.dropped.get(date)
            detail = f"it was dropped: {why}" if why else "it is not a trading day of the split"
            msg = (
                f"day {date} is not available in split `{self.config.split}` ({self.days[0]} .. {self.days[-1]}, "
                f"{len(self.days)} days): {detail}"
            )
            raise ValueError(msg)
        return self._day_of[date]

    # -- Gymnasium API -------------------------------------------------------------------------------

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start a trading day flat (see the class docstring for how the day is chosen)."""
        super().reset(seed=seed)
        n = len(self.days)
        if options and options.get("day") is not None:
            index = self._day_index(options["day"])
        elif self.config.sequential:
            index = seed % n if seed is not None else (self._day + 1) % n if self._started else 0
        else:
            index = int(self.np_random.integers(n))
        self._started = True
        self._load_day(index)
        info = {"day": self.days[index].isoformat(), "mid_price": self._mid[0], "timestamp": self._time[0]}
        return self._obs[FLAT][0], info

    _started = False

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Hold the chosen position over the next ``persistence`` minutes (see the class docstring)."""
        a = self._action(action)
        k = self._k
        if k >= self.n_steps:
            raise RuntimeError("the trading day is over: call `reset()` before `step()`")
        pos = a - 1
        prev = self._pos
        self._positions[k] = pos
        price = self._mid[k + 1]
        pnl = self._cap * pos * (price - self._mid[k])
        fee = self._episode_fee * abs(pos - prev)
        k += 1
        self._k = k
        if k == self.n_steps:
            fee += self._episode_fee * abs(pos if self._close_new else prev)
            self._pos = 0
            obs = self._obs[FLAT][k]
            terminated, truncated = self._terminate, True
        else:
            self._pos = pos
            obs = self._obs[a][k]
            terminated = truncated = False
        self.cum_pnl += pnl
        self.cum_fees += fee
        info = {
            "pnl": pnl,
            "fees": fee,
            "position": pos,
            "mid_price": price,
            "timestamp": self._time[k],
            "cum_pnl": self.cum_pnl,
            "cum_fees": self.cum_fees,
            "reward_components": {"pnl": pnl, "fees": -fee},
            "cost": 0.0,
        }
        return obs, pnl - fee, terminated, truncated, info

    def render(self) -> str | np.ndarray | None:
        """``ansi``: one line on the day so far; ``rgb_array``: the day's prices, coloured by position."""
        if self.render_mode == "ansi":
            k = self._k
            marks = "".join("S-L"[p + 1] for p in self._positions[:k])
            return (
                f"{self.days[self._day]} {str(self._time[k])[11:16]} mid {self._mid[k]:.5f} [{marks:<{self.n_steps}}] "
                f"P&L {self.cum_pnl:+.2f} fees {self.cum_fees:.2f}"
            )
        if self.render_mode == "rgb_array":
            return self._picture()
        return None

    def _picture(self, height: int = 120, width: int = 240) -> np.ndarray:
        img = np.full((height, width, 3), 255, dtype=np.uint8)
        prices = np.asarray(self._mid)
        lo, hi = prices.min(), prices.max()
        span = hi - lo if hi > lo else 1.0
        xs = np.linspace(0, width - 1, len(prices))
        colours = {-1: (200, 30, 30), 0: (120, 120, 120), 1: (30, 150, 30)}
        for i in range(len(prices) - 1):
            colour = colours[self._positions[i]] if i < self._k else (200, 200, 230)
            for x in range(int(xs[i]), int(xs[i + 1]) + 1):
                f = (x - xs[i]) / max(xs[i + 1] - xs[i], 1e-9)
                p = prices[i] + f * (prices[i + 1] - prices[i])
                y = round(float((hi - p) / span * (height - 11))) + 5
                img[y - 1 : y + 2, x] = colour
        return img

    def __repr__(self) -> str:
        return f"TradingEnv(split={self.config.split!r}, days={len(self.days)}, fidelity={self.config.fidelity!r})"
