"""The contact rules every method shares: what happens when the bodies touch, while they stick,
and when the flow changes.

The pure laws live in :mod:`iceimpact.physics.contact` (the impact law of eq. 12-17, the contact
force of free accelerations). This module adds what a solver needs around them:

- the impact step (eq. 12-18) with the closure of an elastic chatter by one plastic impact, and
  a Zeno sequence followed to its end, or closed at its estimated end (:meth:`ContactRules.impact`);
- degenerate contacts, which keep re-forming with no closing speed (:class:`DegenerateContacts`);
- the decision at zero gap: impact, stick or fly (:meth:`ContactRules.at_contact`);
- the sticking phase that replaces the article's steady-state thresholds (eq. 27-29): the bodies
  move together, ``(m + M) x'' + c x' + k x = F_drag(x')`` (:class:`Together`), the contact force
  on the structure is the drag on the ice minus its inertia (:func:`sticking_contact_force`), and
  they separate when it turns tensile (:func:`separates`);
- the bookkeeping of the sticking phase's start (:func:`sticking_start`);
- the re-anchoring of the closed forms when the flow speed changes (zero-order hold,
  :func:`reanchor_on_flow_change`).

The exact method (1) and the ODE method (3) use all of it; the fixed-step method (2) follows the
article's own scheme and uses the impact law and the sticking bookkeeping. Where the exact and the
ODE methods differ, the difference is a named parameter (:class:`ContactPolicy`, the
``inertia_from_net`` rounding of :class:`Together`, the ``free_accels`` of :class:`ContactRules`).
"""

from __future__ import annotations

import enum
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

from ..physics.contact import Impact, contact_force, impact, impact_impulse
from ..record import Record

#: A Zeno sequence (e < 1) whose remaining bounces would all happen within this time (s) is
#: closed by one plastic impact now: sticking then starts within ZENO_TIME of the end of the
#: bounces, and the motion it skips is below ~ closing speed * ZENO_TIME (sub-nanometre).
ZENO_TIME = 1e-9

#: The budget of a Zeno sequence (e < 1), in bounces: it is followed bounce by bounce while the
#: bounces it has left from the first one shorter than the chatter time down to ZENO_TIME number
#: at most this many (~ ln(chatter time / ((1 - e) ZENO_TIME)) / ln(1 / e): 22 at e = 0.5 and
#: 73 at e = 0.8 in the Figure 2 scene, ZENO_BUDGET from e ~ 0.85). A longer one (e close to 1)
#: is closed at its estimated end (:meth:`ContactRules.impact`).
ZENO_BUDGET = 100

#: The exact method follows a bounce only while it lasts at least this many time resolutions of
#: its root search at its time (limits.TIME_RESOLUTION max(1, t)); a shorter one (late in a
#: very long run: 1e-9 s at t = 1e6 s) ends its sequence at its estimated end.
ZENO_RESOLUTION = 64.0

#: A closing speed below ROUNDING_SPEED * (|v| + |w| + |u| + wn |x|) is rounding, not an impact.
ROUNDING_SPEED = 1e-12

#: More than this many contacts with zero closing speed, each within the chatter time of the
#: previous one, mean a degenerate contact (gap and contact force both zero to rounding,
#: as right after a separation): the bodies are then held together for DEGENERATE_HOLD (s),
#: doubling at each further such contact up to the chatter time, so the work stays bounded.
MAX_DEGENERATE_CONTACTS = 8
DEGENERATE_HOLD = 1e-9


class Phase(enum.Enum):
    """What the bodies do in a segment of the motion."""

    FLIGHT = "flight"   # both free: structure on its oscillator, ice on its drag law
    STICK = "stick"     # together, pressed by a compressive contact force


class Outcome(enum.Enum):
    """What follows a contact at zero gap (:meth:`ContactRules.at_contact`)."""

    IMPACT = "impact"   # approaching: apply the impact step now
    STICK = "stick"     # move together from here
    FLIGHT = "flight"   # part (or stay apart) from here


#: The members as module constants: an attribute of an enum class is looked up through its
#: metaclass (about 20 times the cost of a global), and the decisions are made at every contact.
_IMPACT, _STICK, _FLIGHT = Outcome.IMPACT, Outcome.STICK, Outcome.FLIGHT


class ContactDecision(NamedTuple):
    """The decision at a contact: the outcome and the velocities to continue with."""

    outcome: Outcome
    v: float          # structure velocity, m/s (the common velocity for STICK)
    w: float          # ice velocity, m/s
    hold: float = 0.0     # STICK: separation is not looked for during this time, s
    impulse: float = 0.0  # STICK: impulse on the structure of the plastic entry, N.s
    lam: float = math.nan  # FLIGHT: contact force of the free accelerations, N (eq. 12-17 aside)


#: ``_new(cls, values)``: a named tuple from all its values, without the keyword handling of its
#: generated ``__new__`` (twice the cost); used for the records made at every contact.
_new = tuple.__new__


@dataclass(frozen=True)
class ContactPolicy:
    """How a method treats a contact at zero gap; the exact and the ODE methods differ here.

    - ``merge_rounding_closing``: a closing speed at rounding level (either sign) is replaced by
      the common velocity of both bodies (momentum kept) before the decision (exact method: its
      velocities carry rounding only). Otherwise any positive closing speed is an impact.
    - ``stick_slow_parting``: bodies pressed together (lam >= 0) that part too slowly for a
      resolvable bounce (shorter than the chatter time), at a speed within the velocities'
      error (``ContactRules.parting_noise``), stick (ODE method: its velocities carry
      integration error, which would leave an endless chatter). A faster parting is real: the
      plastic entry would pull the ice back (a tensile impulse); the bodies fly apart and meet
      again at an impact. Otherwise only bodies with no relative velocity stick.
    - ``plastic_entry``: the sticking phase starts with the common velocity of a plastic impact
      (eq. 16-17 with e = 0), its impulse counted; otherwise with the structure's velocity (which
      then equals the ice's).
    """

    merge_rounding_closing: bool
    stick_slow_parting: bool
    plastic_entry: bool


#: The exact method's contact policy (method 1).
EXACT_POLICY = ContactPolicy(merge_rounding_closing=True, stick_slow_parting=False,
                             plastic_entry=False)
#: The ODE method's contact policy (method 3).
INTEGRATED_POLICY = ContactPolicy(merge_rounding_closing=False, stick_slow_parting=True,
                                  plastic_entry=True)


def chatter_time(omega_n: float, fraction: float) -> float:
    """The chatter time: ``fraction`` (solver.chatter_fraction) of the structure's natural period
    2 pi / omega_n, s.

    With e = 1 the exact model never stops bouncing: pressed on the structure by the flow, the
    ice makes ever smaller and faster bounces (the impact rate doubles every ~25 s in the Figure
    2 scene) whose mean force is the sticking contact force. A bounce shorter than the chatter
    time ends them with one plastic impact, which bounds the work per simulated second; the
    motion it skips is a bounce of height g'' T^2 / 8 (below ~1e-9 m in the Figure 2 scene at
    the default 1e-2). docs/explanation/accuracy.md ("The chatter threshold") measures its trade."""
    return fraction * 2.0 * math.pi / omega_n


class DegenerateContacts:
    """The rule for contacts that keep re-forming with no closing speed (methods 1 and 3).

    The gap and the contact force can both be zero to rounding (right after a separation, or
    with everything at rest and no force): contact then re-forms at every event. After
    MAX_DEGENERATE_CONTACTS such contacts, each within the chatter time of the previous one, the
    bodies are held together for DEGENERATE_HOLD, doubling at each further one up to the chatter
    time, so that the work per simulated second stays bounded.
    """

    __slots__ = ("chatter_time", "run", "last")

    def __init__(self, chatter_time: float):
        self.chatter_time = chatter_time
        self.run = 0             # contacts in the current run of degenerate ones
        self.last = -math.inf    # time of the latest one, s

    def hold(self, t: float) -> float:
        """Count a contact with no closing speed at time t (s); how long to hold the bodies
        together from t (s), 0 while the run of such contacts is short."""
        if t - self.last > self.chatter_time:
            self.run = 0
        self.run += 1
        self.last = t
        if self.run <= MAX_DEGENERATE_CONTACTS:
            return 0.0
        extra = self.run - MAX_DEGENERATE_CONTACTS
        return min(DEGENERATE_HOLD * 2.0 ** min(extra, 60), self.chatter_time)

    def snapshot(self) -> dict:
        """The counters as plain data (see :meth:`read`)."""
        return {"run": self.run, "last": self.last}

    @staticmethod
    def read(record: Record) -> tuple[int, float]:
        """Validated (run, last) from a snapshot record; set them with :meth:`set`."""
        record.expect_keys(("run", "last"))
        return record.integer("run", low=0), record.real("last", finite=False, high=math.inf)

    def set(self, values: tuple[int, float]) -> None:
        self.run, self.last = values


def sticking_contact_force(drag: float, ice_inertia: float) -> float:
    """Contact force on the structure while the bodies stick, N (>= 0: compressive).

    ``lam = F_drag - M x''``: the drag on the ice minus its inertia, the ice moving with the
    structure (model.md, sticking contact; the article's steady state, eq. 27-29, is its
    constant limit lam = F_drag)."""
    return drag - ice_inertia


def separates(lam: float) -> bool:
    """Separation test: the bodies part when the contact force would turn tensile."""
    return lam < 0.0


class Together:
    """Bodies moving together under the drag on the ice: ``(m + M) x'' + c x' + k x = F_drag(x')``.

    The state for ``solve_ivp`` is ``[x, v, P]``, P the drag impulse on the ice (N.s), so that
    the impulse of the contact force over an interval is ``dP - M dv`` (:meth:`impulse`).

    ``inertia_from_net`` picks the rounding of the ice's inertia ``M x''`` in the contact force:
    ``M * net / (m + M)`` (ODE method) or ``M * (net / (m + M))`` (exact method), net being
    ``F_drag - c v - k x``; the two differ in the last bit, which moves the located separation.
    """

    __slots__ = ("m", "c", "k", "M", "drag", "u", "total", "inertia_from_net")

    def __init__(self, m: float, c: float, k: float, M: float, drag, u: float,
                 inertia_from_net: bool):
        self.m, self.c, self.k, self.M = m, c, k, M
        self.drag, self.u = drag, u
        self.total = m + M
        self.inertia_from_net = inertia_from_net

    def __call__(self, t: float, y) -> list[float]:
        f = self.drag.force(y[1], self.u)
        return [y[1], (f - self.c * y[1] - self.k * y[0]) / self.total, f]

    def jacobian(self, t: float, y) -> list[list[float]]:
        """d(:meth:`__call__`)/dy, for method 3's implicit integrators: exact, the drags' dF/dv
        from their ``force_rate``."""
        df = self.drag.force_rate(y[1], self.u)
        return [[0.0, 1.0, 0.0],
                [-self.k / self.total, (df + self._structure_drag_rate(y[1]) - self.c)
                 / self.total, 0.0],
                [0.0, df, 0.0]]

    def _structure_drag_rate(self, v: float) -> float:
        """dF_s/dv of the Morison drag on the structure, kg/s (none here)."""
        return 0.0

    def contact_force_rate(self, y):
        """d lam / dt at state ``[x, v, ...]``, N/s (rows of arrays: element by element), for
        method 3's look inside its steps: lam = F(v) - M a with a = net / (m + M), so
        ``lam' = F'(v) a - M ((F'(v) + F_s'(v) - c) a - k v) / (m + M)``."""
        v = y[1]
        df = self.drag.force_rate(v, self.u)
        accel = self(0.0, y)[1]
        return df * accel - self.M * ((df + self._structure_drag_rate(v) - self.c) * accel
                                      - self.k * v) / self.total

    @property
    def structure_drag_B(self) -> float:
        """Quadratic Morison drag constant on the structure, kg/m (0: none)."""
        return 0.0

    def contact_force(self, y) -> float:
        """Force on the structure from the ice at state ``[x, v, ...]``, N."""
        x, v = y[0], y[1]
        f = self.drag.force(v, self.u)
        net = f - self.c * v - self.k * x
        if self.inertia_from_net:
            return sticking_contact_force(f, self.M * net / self.total)
        return sticking_contact_force(f, self.M * (net / self.total))

    def impulse(self, ya, yb) -> float:
        """Impulse of the contact force on the structure between states ya and yb, N.s:
        drag impulse on the ice minus its momentum change."""
        return float(self.impulse_array(ya, yb))

    def impulse_array(self, ya, yb):
        """:meth:`impulse` element by element: ya and yb are rows x, v, P of arrays (or one
        state each)."""
        return (yb[2] - ya[2]) - self.M * (yb[1] - ya[1])


class TogetherWithStructureDrag(Together):
    """Bodies moving together with the Morison drag on the structure as well
    (docs/explanation/morison.md):
    ``(m + m_a + M) x'' + c x' + k x = F_drag(x') + F_s(x')``, ``m`` being m + m_a. The contact
    force stays the drag on the ice minus the ice's inertia, and the integrated impulse ``P`` the
    ice's drag impulse: the structure's drag acts on the structure, not through the contact."""

    __slots__ = ("structure_drag",)

    def __init__(self, m: float, c: float, k: float, M: float, drag, u: float,
                 inertia_from_net: bool, structure_drag):
        super().__init__(m, c, k, M, drag, u, inertia_from_net)
        self.structure_drag = structure_drag

    @property
    def structure_drag_B(self) -> float:
        return self.structure_drag.B if self.structure_drag.quadratic else 0.0

    def __call__(self, t: float, y) -> list[float]:
        f = self.drag.force(y[1], self.u)
        f_s = self.structure_drag.force(y[1], self.u)
        return [y[1], (f + f_s - self.c * y[1] - self.k * y[0]) / self.total, f]

    def _structure_drag_rate(self, v: float) -> float:
        return self.structure_drag.force_rate(v, self.u)

    def contact_force(self, y) -> float:
        x, v = y[0], y[1]
        f = self.drag.force(v, self.u)
        net = f + self.structure_drag.force(v, self.u) - self.c * v - self.k * x
        if self.inertia_from_net:
            return sticking_contact_force(f, self.M * net / self.total)
        return sticking_contact_force(f, self.M * (net / self.total))


def make_together(m: float, c: float, k: float, M: float, drag, u: float, inertia_from_net: bool,
                  structure_drag=None) -> Together:
    """The sticking phase's equations: :class:`Together`, or :class:`TogetherWithStructureDrag`
    when the flow drags the structure (``structure_drag`` not None)."""
    if structure_drag is None:
        return Together(m, c, k, M, drag, u, inertia_from_net)
    return TogetherWithStructureDrag(m, c, k, M, drag, u, inertia_from_net, structure_drag)


def sticking_start(was_sticking: bool, since: float | None, sticking: bool,
                   t: float) -> float | None:
    """Start time of the sticking phase (s) after a segment starting at t: kept while the bodies
    stay together, t when they start sticking, None while they are apart."""
    if not sticking:
        return None
    return since if was_sticking else t


def reanchor_on_flow_change(x: float, v: float, z: float, w: float,
                            sticking: bool) -> tuple[float, float, float, float]:
    """State from which a new flow speed restarts the closed forms (zero-order hold).

    Sticking bodies stay together (the ice takes the structure's state); in flight, an ice
    position past the structure by rounding is put back at contact."""
    if sticking:
        return x, v, x, v
    return x, v, min(z, x), w


def rounding_closing(closing: float, x: float, v: float, w: float, u: float,
                     omega_n: float) -> bool:
    """|closing| (m/s) is at rounding level of the speeds of the scene: at most ROUNDING_SPEED
    times ``|v| + |w| + |u| + omega_n |x|``.

    (Asked twice per impact: the magnitudes are written as comparisons, a call of abs() costing
    more than the rest in Python; the sign of a zero term cannot change the outcome.)"""
    speed_scale = ((v if v >= 0.0 else -v) + (w if w >= 0.0 else -w)
                   + (u if u >= 0.0 else -u) + omega_n * (x if x >= 0.0 else -x))
    limit = ROUNDING_SPEED * speed_scale + 1e-300
    return -limit <= closing <= limit


def bounce_closure(t: float, x: float, e: float, lam: float, opening: float, mu: float,
                   chatter_time: float, follow_zeno: bool, budget_bounce: float,
                   time_resolution: float, gap_relative: float,
                   gap_absolute: float) -> tuple[bool, float]:
    """Whether an impact at time t (s), position x (m), restitution e > 0 closes its chatter or
    Zeno sequence by one plastic impact now (:meth:`ContactRules.impact` says when), and the
    estimated end of the sequence (s) when it is closed before that end (NaN otherwise).

    ``lam`` (N) is the free contact force after the impact, ``opening`` (m/s) the opening speed
    v+ - w+; the next bounce lasts ``2 opening mu / lam``. ``budget_bounce`` is
    :meth:`ContactRules.budget_bounce` of e; ``time_resolution`` and the gap noise (relative
    to |x|, absolute in m) are the method's (:meth:`ContactRules.impact`). A function over
    plain floats: the compiled march of the exact method (solvers/exact/bounces.py) calls it
    too."""
    if not lam > 0.0:
        return False, math.nan
    bounce = 2.0 * opening * mu / lam
    close = bounce < chatter_time or bounce < ZENO_TIME * (1.0 - e)
    if e < 1.0 and follow_zeno:
        rest = bounce / (1.0 - e)  # the geometric series of the bounces
        close = rest < ZENO_TIME
        if not close and (
                bounce < time_resolution * (t if t > 1.0 else 1.0)
                or opening * bounce < 4.0 * (gap_relative * abs(x) + gap_absolute)
                or (bounce < chatter_time and bounce > budget_bounce)):
            return True, t + rest
    return close, math.nan


FreeAccels = Callable[[float, float, float, float], tuple[float, float]]


class ContactRules:
    """The contact rules of one scene for one method: impact step, degenerate contacts, the
    decision at zero gap.

    ``free_accels(x, v, w, u) -> (a_x, a_z)`` gives the free accelerations of structure and ice
    (each method evaluates the ice's drag acceleration its own way, to the last bit);
    ``policy`` is the method's :class:`ContactPolicy`; ``parting_noise`` = (relative, absolute
    in m/s) the error of the method's velocities (its integration tolerance).
    """

    def __init__(self, m: float, M: float, omega_n: float, free_accels: FreeAccels,
                 policy: ContactPolicy, chatter_fraction: float,
                 parting_noise: tuple[float, float] = (0.0, 0.0),
                 time_resolution: float = 0.0, gap_noise: tuple[float, float] = (0.0, 0.0),
                 follow_zeno: bool = True):
        self.m, self.M = m, M
        self.mu = m * M / (m + M)   # reduced mass, kg
        self.omega_n = omega_n
        self.chatter_time = chatter_time(omega_n, chatter_fraction)
        self.free_accels = free_accels
        self.policy = policy
        self.parting_noise = parting_noise
        # the shortest bounce the method follows: time_resolution max(1, t) (s), and a height
        # above gap_noise = (relative to |x|, absolute in m), the noise of its positions
        self.time_resolution = time_resolution
        self.gap_noise = gap_noise
        # False: a Zeno sequence is closed at the chatter time, as an elastic chatter is (an
        # external structure, whose motion over the bounces the coupling does not resolve)
        self.follow_zeno = follow_zeno
        self.degenerate = DegenerateContacts(self.chatter_time)
        # the estimated end of the Zeno sequence the latest impact closed before it (s), until
        # the solver takes it (take_accumulation); None when it closed none, or at its end
        self.accumulation: float | None = None
        self._budget: tuple[float, float] = (math.nan, math.nan)  # (e, its budget_bounce)

    def budget_bounce(self, e: float) -> float:
        """The longest bounce (s) of a Zeno sequence of restitution 0 < e < 1 whose bounces left
        down to ZENO_TIME are at most ZENO_BUDGET: ``(1 - e) ZENO_TIME / e^ZENO_BUDGET`` (a
        bounce b leaves ``ln(b / ((1 - e) ZENO_TIME)) / ln(1 / e)`` of them, their durations a
        geometric series of ratio e). Kept for the latest e (impact.e is tunable)."""
        if self._budget[0] != e:
            power = e ** ZENO_BUDGET  # (0 for e below ~1e-3: no sequence is that long)
            self._budget = (e, (1.0 - e) * ZENO_TIME / power if power > 0.0 else math.inf)
        return self._budget[1]

    def take_accumulation(self) -> float | None:
        """The estimated end (s) of the Zeno sequence the latest impact closed before it, once
        (then None): the solver moves the bodies together to it, and sticking starts there."""
        end, self.accumulation = self.accumulation, None
        return end

    def free_contact_force(self, x: float, v: float, w: float, u: float) -> float:
        """Contact force needed to keep the bodies together at state (x, v, w), N: the
        separation test at a contact (< 0: they part)."""
        a_x, a_z = self.free_accels(x, v, w, u)
        return contact_force(a_x, a_z, self.m, self.M)

    def is_rounding(self, closing: float, x: float, v: float, w: float, u: float) -> bool:
        """|closing| (m/s) is at rounding level of the speeds of the scene
        (:func:`rounding_closing`)."""
        return rounding_closing(closing, x, v, w, u, self.omega_n)

    def impact(self, t: float, x: float, v_minus: float, w_minus: float, e: float,
               u: float) -> Impact:
        """The impact step at time t (s), position x (m): eq. 16-17, positions unchanged (eq. 18).

        If the ice stays pressed on the structure after the impact (contact force lam > 0), its
        next bounce lasts ``bounce = 2 s mu / lam`` (opening speed s, reduced mass mu: the gap
        is a parabola of curvature -lam / mu) and each later one ~ e times the one before.

        - e = 1 (chatter closure): a bounce shorter than the chatter time is replaced by one
          plastic impact (e = 0) now, after which the bodies move together.
        - 0 < e < 1 (a Zeno sequence): its bounces add up to ``bounce / (1 - e)``; the
          sequence ends at that accumulation time. It is followed bounce by bounce, and closed
          by one plastic impact now once its remaining bounces would all happen within
          ZENO_TIME. Where following it would cost more than ZENO_BUDGET bounces (from the
          chatter time on: e close to 1), or its next bounce is too short for the method to
          resolve (``time_resolution``, ``gap_noise``), it is closed at its estimated end
          instead: the plastic impact now keeps the momentum the remaining bounces keep, the
          bodies move together (the mean motion of bounces short against the structure's
          period), and sticking starts at ``t + bounce / (1 - e)``, which
          :meth:`take_accumulation` hands to the solver.

        Without ``follow_zeno`` a Zeno sequence is closed as an elastic chatter is, at its first
        bounce shorter than the chatter time (or once it would end within ZENO_TIME).
        """
        m, M = self.m, self.M
        v_plus, w_plus = impact(v_minus, w_minus, m, M, e)
        if e > 0.0:
            lam = self.free_contact_force(x, v_plus, w_plus, u)
            relative, absolute = self.gap_noise
            budget = self._budget  # (budget_bounce, inline: this runs at every impact)
            close, accumulation = bounce_closure(
                t, x, e, lam, v_plus - w_plus, self.mu, self.chatter_time, self.follow_zeno,
                budget[1] if budget[0] == e else self.budget_bounce(e), self.time_resolution,
                relative, absolute)
            if close:
                if accumulation == accumulation:
                    self.accumulation = accumulation
                e = 0.0
                v_plus, w_plus = impact(v_minus, w_minus, m, M, 0.0)
        if e == 0.0:
            w_plus = v_plus  # exactly together
        return _new(Impact, (t, x, v_minus, w_minus, v_plus, w_plus,
                             impact_impulse(v_minus, v_plus, m), e))

    def impact_at_contact(self, t: float, x: float, v: float, w: float, e: float,
                          u: float) -> tuple[Impact | None, bool]:
        """:meth:`at_contact` and :meth:`impact` in one for the common contact, a flight ending
        in an approach: (the Impact, whether the bodies then part) if at_contact decides an
        impact at (x, v, w), else (None, False), with nothing changed (at_contact decides then).

        ``parts``: at the velocities after the impact at_contact would decide a flight with an
        opening speed beyond rounding (e > 0, a bounce): the flight starts at the contact, its
        search from 0 (the solver's ``_fly_from_contact``), and at_contact is not asked again.
        Its other outcomes (a plastic impact, an opening at rounding level) are left to it.
        The decisions are at_contact's, to the bit: the same rounding test on the same values
        (no counter of :class:`DegenerateContacts` moves when the speed is beyond rounding)."""
        closing = w - v
        # (is_rounding, inline: this runs at every impact)
        if not closing > 0.0 or rounding_closing(closing, x, v, w, u, self.omega_n):
            return None, False
        result = self.impact(t, x, v, w, e, u)
        v_plus, w_plus = result[4], result[5]
        closing = w_plus - v_plus
        return result, closing < 0.0 and not rounding_closing(closing, x, v_plus, w_plus, u,
                                                              self.omega_n)

    def plastic_merge(self, v: float, w: float) -> tuple[float, float]:
        """Common velocity of a plastic impact (eq. 16-17, e = 0), m/s, and its impulse on the
        structure, N.s: how the bodies start sticking under ``plastic_entry``."""
        v_common, _ = impact(v, w, self.m, self.M, 0.0)
        return v_common, impact_impulse(v, v_common, self.m)

    def _stick(self, v: float, w: float, hold: float = 0.0) -> ContactDecision:
        if self.policy.plastic_entry:
            v_common, impulse = self.plastic_merge(v, w)
            return _new(ContactDecision, (_STICK, v_common, v_common, hold, impulse, math.nan))
        return _new(ContactDecision, (_STICK, v, v, hold, 0.0, math.nan))

    def tensile(self, lam: float, x: float, v: float, w: float, u: float) -> bool:
        """The contact force lam (N) at state (x, v, w) pulls beyond its rounding: the bodies
        must part, and no hold may keep them together.

        lam = mu (a_z - a_x) is computed from the free accelerations, whose rounding is a few ulps
        of the terms they add up (the spring term omega_n^2 x of a_x may cancel its damping
        term); ROUNDING_SPEED of that sum is rounding, not a force."""
        a_x, a_z = self.free_accels(x, v, w, u)
        scale = self.mu * (abs(a_x) + abs(a_z) + self.omega_n * self.omega_n * abs(x))
        return lam < -(ROUNDING_SPEED * scale + 1e-300)

    def at_contact(self, t: float, x: float, v: float, w: float, u: float,
                   reanchor: bool = False) -> ContactDecision:
        """What follows at time t (s) with the bodies at zero gap at x (m), velocities v, w.

        An approach is an impact; contact with no relative velocity that keeps re-forming is
        held (:class:`DegenerateContacts`) unless its force pulls beyond rounding; bodies pressed
        together (lam >= 0) with no relative velocity stick; all else parts. The method's
        :class:`ContactPolicy` decides the rounding-level cases.

        ``reanchor``: the decision is not that of a contact re-forming, and is not counted as a
        degenerate contact: it follows a change of the flow speed (the closed forms restart at
        the bodies' state, :func:`reanchor_on_flow_change`), or an impact (the velocities after
        it, equal after a plastic one: the closing speed the impact resolved was real). Counted,
        repeated real impacts would hold the bodies with no look for a separation
        (docs/explanation/robustness/contact.md#contact-after-impact).
        """
        policy = self.policy
        closing = w - v
        rounding = self.is_rounding(closing, x, v, w, u)
        if policy.merge_rounding_closing and closing != 0.0 and rounding:
            # a closing speed at rounding level is no impact: merge the velocities
            # (momentum kept) and let the contact logic below decide
            v = w = (self.m * v + self.M * w) / (self.m + self.M)
            closing = 0.0
        if closing > 0.0:  # approaching at contact: impact now
            return _new(ContactDecision, (_IMPACT, v, w, 0.0, 0.0, math.nan))
        lam = self.free_contact_force(x, v, w, u)
        if rounding and not reanchor and not self.tensile(lam, x, v, w, u):
            # contact that keeps re-forming with no speed (contact force zero to rounding, e.g.
            # everything at rest with no flow): hold the bodies together for a while. A contact
            # that pulls is never held: a contact can only push
            hold = self.degenerate.hold(t)
            if hold > 0.0:
                return self._stick(v, w, hold)
        if policy.stick_slow_parting:
            # pressed together and parting too slowly for a resolvable bounce (rounding of a
            # separation, the tail of a chatter): stick
            relative, absolute = self.parting_noise
            noise = relative * (abs(v) + abs(w) + abs(u)) + absolute
            stick = (lam >= 0.0 and -closing <= noise
                     and -2.0 * closing * self.mu <= lam * self.chatter_time)
        else:
            stick = closing == 0.0 and lam >= 0.0
        if stick:
            return self._stick(v, w)
        return _new(ContactDecision, (_FLIGHT, v, w, 0.0, 0.0, lam))
