"""An independent reference for Zeno sequences: the linear-drag scene (eq. 4-10, 12-17 and the
sticking phase of docs) in closed form, in 80-digit arithmetic (mpmath), followed bounce by bounce
until the bounces left would all fit in ``tail`` seconds (1e-24 s by default).

It shares no code with :mod:`iceimpact`: the closed forms, the impact law, the contact force and
the root search are written out here. Each event is the first root of a function f (the gap x - z
in flight, the contact force while the bodies stick) found by certified steps: from a point where
f >= 0 with rate f', a step h for which ``f + f' h - F2 h^2 / 2 > 0``, F2 a bound on |f''| over
the whole segment (the closed forms' amplitudes: an under-damped oscillator's n-th derivative never
exceeds its amplitude times omega_n^n, an exponential's its start value times rate^n), cannot
step over a root. They converge on the root like Newton's method. A flight that starts where the
bodies part with equal velocities (f = f' = 0) takes its first step from the fourth-order bound
``f'' h^2 / 2 + f''' h^3 / 6 - F4 h^4 / 24 > 0``.

Valid for an under-damped structure and under-damped bodies together, linear drag, constant flow.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mpmath as mp

#: Working precision (decimal digits): a bounce of 1e-24 s has a height of ~1e-50 m at
#: positions of 1e-3 m, and its root is located to 1e-35 s.
DIGITS = 80
#: A certified step shorter than this (s) has reached the root.
CONVERGED = mp.mpf("1e-35")


@dataclass
class Events:
    """Impacts (t, v-, w-, v+, w+), sticking starts and releases (s) of a reference run."""

    impacts: list[tuple] = field(default_factory=list)
    stick_starts: list = field(default_factory=list)
    releases: list = field(default_factory=list)


class _Damped:
    """``y(tau) = offset + exp(-sigma tau) (P cos(wd tau) + Q sin(wd tau))``: the free motion of
    mass, damping, stiffness about ``offset`` from (y0, y0')."""

    def __init__(self, mass, damping, stiffness, offset, y0, v0):
        self.sigma = damping / (2 * mass)
        self.wn = mp.sqrt(stiffness / mass)
        self.wd = mp.sqrt(self.wn ** 2 - self.sigma ** 2)
        self.offset = offset
        self.P = y0 - offset
        self.Q = (v0 + self.sigma * self.P) / self.wd
        self.amplitude = mp.sqrt(self.P ** 2 + self.Q ** 2)

    def derivatives(self, tau, n):
        """[y, y', ..., y^(n)] at tau."""
        decay, c, s = mp.exp(-self.sigma * tau), mp.cos(self.wd * tau), mp.sin(self.wd * tau)
        P, Q = self.P, self.Q
        out = [self.offset + decay * (P * c + Q * s)]
        for _ in range(n):
            P, Q = -self.sigma * P + self.wd * Q, -self.wd * P - self.sigma * Q
            out.append(decay * (P * c + Q * s))
        return out

    def bound(self, n):
        """A bound on |y^(n)| for all tau >= 0 (n >= 1)."""
        return self.amplitude * self.wn ** n


class _Ice:
    """The ice under linear drag (eq. 6-7): relative speed r = w - u decays at beta = b / M."""

    def __init__(self, beta, u, z0, w0):
        self.beta, self.u, self.z0, self.r0 = beta, u, z0, w0 - u

    def derivatives(self, tau, n):
        decay = mp.exp(-self.beta * tau)
        out = [self.z0 + self.u * tau + self.r0 * (1 - decay) / self.beta,
               self.u + self.r0 * decay]
        term = self.r0 * decay
        for _ in range(n - 1):
            term = -self.beta * term
            out.append(term)
        return out

    def bound(self, n):
        return abs(self.r0) * self.beta ** (n - 1)


def _first_root(value, bound2, horizon, start_step=None):
    """First root (s) of f on 0 < tau <= horizon by certified steps (None if there is none);
    ``value(tau)`` gives (f, f') with f >= 0 up to the root, ``bound2`` bounds |f''|,
    ``start_step`` a certified first step."""
    tau = mp.mpf(0) if start_step is None else start_step
    while tau <= horizon:
        f, rate = value(tau)
        if f <= 0 and tau > 0:
            return tau
        step = (rate + mp.sqrt(rate * rate + 2 * bound2 * f)) / bound2
        if step < CONVERGED:
            return tau + f / abs(rate) if rate < 0 else tau + step
        tau += step
    return None


class ZenoReference:
    """The scene's events to ``t_end`` (s); a Zeno sequence is followed until the bounces left
    would fit in ``tail`` (s), then the bodies stick."""

    def __init__(self, m, c, k, M, b, u, e, x0, v0, z0, w0, tail="1e-24", t0=0.0):
        mp.mp.dps = DIGITS
        f = mp.mpf
        self.m, self.c, self.k, self.M, self.b, self.u, self.e = (
            f(m), f(c), f(k), f(M), f(b), f(u), f(e))
        self.mu = self.m * self.M / (self.m + self.M)
        self.state = (f(t0), f(x0), f(v0), f(z0), f(w0))
        self.tail = f(tail)
        assert 0 < e < 1, "a Zeno sequence needs 0 < e < 1"

    def _accels(self, x, v, w):
        return -(self.c * v + self.k * x) / self.m, -self.b * (w - self.u) / self.M

    def contact_force(self, x, v, w):
        """Force keeping the bodies together at (x, v, w), N: mu (a_z - a_x) (< 0: they part)."""
        a_x, a_z = self._accels(x, v, w)
        return self.mu * (a_z - a_x)

    def run(self, t_end, max_impacts=None) -> Events:
        """The events to t_end (s), or to the ``max_impacts``-th impact."""
        t_end = mp.mpf(t_end)
        events = Events()
        t, x, v, z, w = self.state
        sticking, released = False, False
        while t < t_end:
            if sticking:
                released_at = self._stick(t, x, v, t_end)
                if released_at is None:
                    break
                t, x, v = released_at
                events.releases.append(t)
                z, w, sticking, released = x, v, False, True
                continue
            hit = self._fly(t, x, v, z, w, released, t_end)
            released = False
            if hit is None:
                break
            t, x, v_m, w_m = hit
            total = self.m + self.M
            momentum = self.m * v_m + self.M * w_m
            v = (momentum + self.e * self.M * (w_m - v_m)) / total  # eq. 16
            w = (momentum - self.e * self.m * (w_m - v_m)) / total  # eq. 17
            events.impacts.append((t, v_m, w_m, v, w))
            if max_impacts is not None and len(events.impacts) >= max_impacts:
                break
            z = x
            lam = self.contact_force(x, v, w)
            if lam > 0 and 2 * (v - w) * self.mu / lam / (1 - self.e) < self.tail:
                v = w = momentum / total  # the sequence's limit: together
                sticking = True
                events.stick_starts.append(t)
        return events

    def _fly(self, t, x, v, z, w, from_release, t_end):
        """The flight from (x, v, z, w) at t to the next impact: (t, x, v-, w-), None if not
        before t_end."""
        osc = _Damped(self.m, self.c, self.k, 0, x, v)
        ice = _Ice(self.b / self.M, self.u, z, w)

        def gap(tau, n=1):
            xs, zs = osc.derivatives(tau, n), ice.derivatives(tau, n)
            return [a - b for a, b in zip(xs, zs, strict=True)]

        bound2 = osc.bound(2) + ice.bound(2)
        start = None
        if from_release:  # g = g' = 0: the fourth-order bound (see the module docstring)
            _, _, g2, g3 = gap(mp.mpf(0), 3)
            bound4 = osc.bound(4) + ice.bound(4)
            start = (g3 / 6 + mp.sqrt(g3 * g3 / 36 + bound4 * g2 / 12)) / (bound4 / 12)
        tau = _first_root(lambda s: tuple(gap(s)), bound2, t_end - t, start)
        if tau is None:
            return None
        xs, ws = osc.derivatives(tau, 1), ice.derivatives(tau, 1)
        return t + tau, xs[0], xs[1], ws[1]

    def _stick(self, t, x, v, t_end):
        """The bodies together from (x, v) at t until the contact force turns tensile: the
        release (t, x, v), None if not before t_end."""
        total = self.m + self.M
        osc = _Damped(total, self.c + self.b, self.k, self.b * self.u / self.k, x, v)

        def force(tau):  # lam = b (u - v) - M x'', and its rate
            _, y1, y2, y3 = osc.derivatives(tau, 3)
            return self.b * (self.u - y1) - self.M * y2, -self.b * y2 - self.M * y3

        bound2 = self.b * osc.bound(3) + self.M * osc.bound(4)
        tau = _first_root(force, bound2, t_end - t)
        if tau is None:
            return None
        tau += CONVERGED / 10 ** 5  # just past the root: the contact force pulls there
        ys = osc.derivatives(tau, 1)
        assert force(tau)[0] < 0
        return t + tau, ys[0], ys[1]


def default_scene(e: float, t0: float = 0.0, state=(0.0, 0.0, -0.01, 0.01),
                  **kw) -> ZenoReference:
    """The article's Figure 2 scene (linear drag) with restitution e < 1, from ``state`` (x, v,
    z, w) at t0 (default: the scene's start); the parameters are the doubles a scene holds,
    taken exactly."""
    b = 0.5 * 999.0 * 1.0 * 1.0 * 0.1  # rho Cd A v_lin / 2 (eq. 5, 30), as a double
    return ZenoReference(1600.0, 200.0, 1e6, 1600.0, b, 0.1, e, *state, t0=t0, **kw)
