#!/usr/bin/env python3
"""Predicts the time and efficiency of a distributed cierzo render on N nodes x C threads by
simulating its protocol event by event (docs/distributed.md). Standard library only.

Simulated. Tiles of 16 x 16 pixels; passes as pass_bounds() in src/integrators/render.cpp. A
unit (one tile x one pass) costs t_u x paths/16 x its tile's factor (a smooth field, 1/S..S,
--tile-spread) x a lognormal spread (--unit-cv) on one thread, drawn once from --seed, so every
N renders the same work. Tiles in row order are cut into N contiguous ranges; rank r owns range
r and adds its passes. Each rank has C render threads fed from a local queue, one main thread
(a FIFO server: rank 0's requests, reports and sends; an owner's adds of units others rendered,
--owner-add-seconds each, an upper bound: cierzo adds them on a render thread; an owner's own
units are added by its render thread, within t_u), and
one link of bandwidth B each way (a message holds the sender's and the receiver's link) plus L
per message. A rank holding (queued + running) at most low = max(C, high/2) units asks rank
0 for high - held, high = max(4C, 0.020 s x C / t_u) but at most max(C, T/N), one request
out at a time
(rank_protocol.cpp's kQueuedSeconds and kQueuedPerThread). Rank 0 deals
only passes f (in progress) and f+1: to rank r its own tiles of f, of f+1, then the last tiles
of the owner with the most left of f, then of f+1 (cierzo takes from the band after the
last one taken from, round robin: the same while bands run out evenly), at most 2T/N units
a grant (UnitDealer::grant's cap), at s_req + s_unit x units of CPU. Granting
nothing, it answers a rank that holds units at once and parks the requests of ranks that hold
none until the pass advances, as rank_protocol.cpp does; a rank answered empty asks again once
one of its units is done (--empty park: every such request is parked). A unit rendered off its
owner sends its sums (--bytes-per-unit) to the owner. With --estimator bdpt every unit also
makes --splat-bytes-per-unit x paths/16 bytes of splats spread evenly over the owners: when a
pass is dealt out rank 0 tells every rank (N sends); each rank, after its last unit of it,
sends each owner its share; an owner's link takes the shares in the order sent, none before its
sender's link has sent it. An owner's pass is complete when its tiles (and the N shares) are
in; it reports to rank 0 (s_report), which advances f when all N have, with a message to every
rank (s_send each), and opens f+2.

Extrapolated or added. The passes of fewer than 16 paths and K = --passes of 16 (the last of
them the render's last pass, so its drain is simulated) are simulated. The other passes (all of
16 paths) are added at the steady time per pass: a 16-path pass's work over the rate of work
(unit thread-seconds, running units' part included) from rank 0's advance past the window's 3rd
16-path pass to the one past its next-to-last (an even number of passes apart: at scale passes
alternate long and short, two being in flight). Rank 0 busy, bytes per unit (sums and splats),
stolen and idle are of that span (of the whole window if nothing is extrapolated). The end
gather is analytic: every owner's pixels but rank 0's (64 bytes each) through rank 0's link,
bytes / B + L + megapixels x --gather-seconds-per-megapixel. Checkpoints: one is simulated
mid-window (the same gather in the background: the links and rank 0's main thread); its delay
against the window without it is added once per --checkpoint-every of the predicted time. Not
modelled: the final checkpoint, loading the scene, the CPU of adding splats, the main threads'
polling (they sleep up to 1 ms when idle) and competing with render threads for cores (at scale
give rank 0 one render thread fewer).

Floors beside the simulation: rank 0's CPU, U x (s_unit + s_req / high) + passes x N x
(s_report + s_send, twice with splats) (analytic: every grant full), and the simulated CPU per
unit x U; the work over min(N x C, 2T) threads (at most two passes of T tiles are dealt at a
time); the end gather.

    python3 bench/mpi_scaling.py [--nodes 1,10,100,1000] [--threads 64] [--t-u 2.1e-3]
        [--estimator bdpt --splat-bytes-per-unit BYTES] [--calibration FILE] [--json FILE]
    python3 bench/mpi_scaling.py --self-test
"""
import argparse, heapq, json, math, random, sys, time
from collections import deque
from types import SimpleNamespace

import benchlib

TILE, PIXEL_BYTES = 16, 64       # a film pixel's sums are 64 bytes
MIN_PASS_PATHS = 1 << 20         # kMinPassPaths, src/integrators/render.h
DEFAULTS = dict(width=3840, height=2160, spp=4096, threads=64, estimator="mis", empty="answer",
                passes=8, unit_cv=0.3, tile_spread=2.0, seed=1, latency=5e-6, bandwidth=10e9,
                s_report=1e-6, s_send=0.5e-6, checkpoint_every=0.0, t_u=2.1e-3, s_req=2e-6,
                s_unit=0.2e-6, bytes_per_unit=16480, splat_bytes=None, s_add=10e-6, gather_mp=0.01)
CALIBRATED = {"t_u_seconds": "t_u", "rank0_seconds_per_request": "s_req",  # --calibration keys
              "rank0_seconds_per_unit": "s_unit", "bytes_per_unit": "bytes_per_unit",
              "splat_bytes_per_unit": "splat_bytes", "owner_add_seconds_per_unit": "s_add",
              "gather_seconds_per_megapixel": "gather_mp"}


def settings(**kw):
    return SimpleNamespace(**{**DEFAULTS, **kw})


def pass_bounds(spp, pixels):
    """Paths per pixel at each pass boundary, as pass_bounds() in src/integrators/render.cpp."""
    bounds, kept, b = [0], 0, 1
    while b < spp + 16:
        if not (b < 16 and b < spp and (b - kept) * max(pixels, 1) < MIN_PASS_PATHS):
            kept, end = b, min(b, spp)
            if end > bounds[-1]:
                bounds.append(end)
            if end == spp:
                break
        b = 2 * b if b < 16 else b + 16
    return bounds


def tile_factors(tx, ty, spread, rng):
    """A smooth cost field (three random waves) from 1/spread to spread, then scaled to mean 1
    so that t_u stays the mean unit's cost."""
    waves = [(rng.uniform(0.5, 2), rng.uniform(0.5, 2), rng.uniform(0, 2 * math.pi)) for _ in range(3)]
    v = [sum(math.sin(2 * math.pi * (fx * x / tx + fy * y / ty) + ph) for fx, fy, ph in waves)
         for y in range(ty) for x in range(tx)]
    lo, hi = min(v), max(v)
    f = [spread ** (2 * (x - lo) / (hi - lo) - 1) if hi > lo else 1.0 for x in v]
    mean = sum(f) / len(f)
    return [x / mean for x in f]


class Work:
    """The render's passes, the window of them simulated, and the window's units' costs."""

    def __init__(self, cfg):
        tx, ty = -(-cfg.width // TILE), -(-cfg.height // TILE)
        self.tiles = T = tx * ty
        self.tile_pixels = [min(TILE, cfg.width - TILE * x) * min(TILE, cfg.height - TILE * y)
                            for y in range(ty) for x in range(tx)]
        self.splats = cfg.estimator == "bdpt"
        b = pass_bounds(cfg.spp, MIN_PASS_PATHS if self.splats else cfg.width * cfg.height)
        paths = [b[i + 1] - b[i] for i in range(len(b) - 1)]
        self.total_passes, self.units = len(paths), T * len(paths)
        self.short = next((i for i, p in enumerate(paths) if p >= 16), len(paths))
        k = self.short + cfg.passes
        self.window = list(range(len(paths))) if len(paths) <= k else list(range(k - 1)) + [len(paths) - 1]
        self.extra = len(paths) - len(self.window)  # 16-path passes not simulated
        self.paths = [paths[i] for i in self.window]
        rng = random.Random(cfg.seed)
        factor = tile_factors(tx, ty, cfg.tile_spread, rng)
        sigma = math.sqrt(math.log(1 + cfg.unit_cv ** 2))
        self.cost = [cfg.t_u * p / 16 * f * rng.lognormvariate(-sigma * sigma / 2, sigma)
                     for p in self.paths for f in factor]
        per_pass = [sum(self.cost[j * T:(j + 1) * T]) for j in range(len(self.window))]
        full = [w for w, p in zip(per_pass[:-1], self.paths[:-1]) if p == 16] or [0.0]
        self.full_pass = sum(full) / len(full)  # thread-seconds of a 16-path pass
        self.total = sum(per_pass) + self.extra * self.full_pass


class Sim:
    """The window on n ranks: an event heap of (time, seq, handler, args), handled in order."""

    def __init__(self, work, cfg, n, speed=None, checkpoint_pass=None):
        self.w, self.cfg, self.n, self.c, self.ck_pass = work, cfg, n, cfg.threads, checkpoint_pass
        T, self.P = work.tiles, len(work.window)
        P = self.P  # simulated passes
        self.start = [r * T // n for r in range(n + 1)]
        self.owner = [r for r in range(n) for _ in range(self.start[r], self.start[r + 1])]
        self.speed = speed or [1.0] * n
        self.high = min(max(4 * self.c, int(0.020 * self.c / cfg.t_u)), max(self.c, T // n))
        self.low = max(self.c, self.high // 2)
        self.heap, self.seq = [], 0
        self.queue, self.free, self.asking = [deque() for _ in range(n)], [self.c] * n, [False] * n
        self.done_since_ask = [0] * n
        self.jobs, self.busy, self.busy_s = [deque() for _ in range(n)], [False] * n, [0.0] * n
        self.out_free, self.in_free = [0.0] * n, [0.0] * n
        self.f, self.parked, self.reports = 0, [], [0] * P
        self.lo, self.hi, self.rich, self.left = [None] * P, [None] * P, [None] * P, [0] * P
        self.missing = [[self.start[o + 1] - self.start[o] for o in range(n)] for _ in range(P)]
        self.owner_next, self.splats_in = [0] * n, [not work.splats] * P
        if work.splats:
            self.held, self.rendered = [[0] * P for _ in range(n)], [[0] * P for _ in range(n)]
            self.told, self.dealt = [[False] * P for _ in range(n)], [False] * P
            self.splat_sends = [[] for _ in range(P)]
        self.units = self.stolen = self.grants = self.bytes_sent = 0
        self.work, self.rate, self.last = 0.0, 0.0, 0.0  # work done: the integral of rate
        self.snaps = [self.snap(0.0)] + [None] * P  # the counters at the start and each advance
        self.open_pass(0)
        self.open_pass(1)
        for r in range(n):
            self.ask(0.0, r)

    def at(self, t, fn, *args):
        self.seq += 1
        heapq.heappush(self.heap, (t, self.seq, fn, args))

    def run(self):
        while self.heap:
            t, _, fn, args = heapq.heappop(self.heap)
            fn(t, *args)
        if self.f < self.P:
            raise RuntimeError(f"simulation stalled at pass {self.f} of {self.P} on {self.n} ranks")
        return self

    def lat(self, a, b):
        return 0.0 if a == b else self.cfg.latency

    def snap(self, t):
        return dict(t=t, work=self.work + self.rate * (t - self.last), busy0=self.busy_s[0],
                    units=self.units, stolen=self.stolen, bytes=self.bytes_sent, grants=self.grants)

    def send(self, now, src, dst, nbytes):
        """A message over both nodes' links (each carries one at a time); returns its arrival."""
        if src == dst:
            return now
        start = max(now, self.out_free[src], self.in_free[dst])
        self.out_free[src] = self.in_free[dst] = start + nbytes / self.cfg.bandwidth
        self.bytes_sent += nbytes
        return self.out_free[src] + self.cfg.latency

    # A rank's main thread: one job at a time, in order of arrival; a job returns its CPU time
    def submit(self, now, r, job, *args):
        self.jobs[r].append((job, args))
        if not self.busy[r]:
            self.next_job(now, r)

    def next_job(self, now, r):
        self.busy[r] = bool(self.jobs[r])
        if self.busy[r]:
            job, args = self.jobs[r].popleft()
            cost = job(now, *args)
            self.busy_s[r] += cost
            self.at(now + cost, self.next_job, r)

    # A rank's render threads
    def ask(self, now, r):
        held = len(self.queue[r]) + self.c - self.free[r]
        if not self.asking[r] and held <= self.low:
            self.asking[r], self.done_since_ask[r] = True, 0
            self.at(now + self.lat(r, 0), self.submit, 0, self.grant, r, self.high - held, held)

    def receive(self, now, r, units):
        self.asking[r] = False
        self.queue[r].extend(units)
        self.start_units(now, r)
        if units or self.done_since_ask[r]:  # after an empty answer, once a unit is done
            self.ask(now, r)

    def working(self, now, speed):
        self.work += self.rate * (now - self.last)
        self.rate, self.last = self.rate + speed, now

    def start_units(self, now, r):
        q, speed = self.queue[r], self.speed[r]
        while self.free[r] and q:
            u = q.popleft()
            self.free[r] -= 1
            self.working(now, speed)
            self.at(now + self.w.cost[u] / speed, self.unit_done, r, u)

    def unit_done(self, now, r, u):
        self.free[r] += 1
        self.units += 1
        self.done_since_ask[r] += 1
        self.working(now, -self.speed[r])
        p, tile = divmod(u, self.w.tiles)
        o = self.owner[tile]
        if o == r:
            self.tile_in(now, o, p)
        else:  # stolen: its sums go to the owner, whose main thread adds them
            self.stolen += 1
            self.at(self.send(now, r, o, self.cfg.bytes_per_unit), self.submit, o, self.add, o, p)
        if self.w.splats:
            self.rendered[r][p] += 1
            self.held[r][p] -= 1
            if self.held[r][p] == 0 and self.told[r][p]:
                self.send_splats(now, r, p)
        self.start_units(now, r)
        self.ask(now, r)

    # Owners
    def add(self, now, o, p):
        self.at(now + self.cfg.s_add, self.tile_in, o, p)
        return self.cfg.s_add

    def tile_in(self, now, o, p):
        self.missing[p][o] -= 1
        if self.missing[p][o] == 0:
            self.owner_check(now, o)

    def owner_check(self, now, o):
        """Reports to rank 0 each pass of o's that is complete, in pass order."""
        p = self.owner_next[o]
        while p < self.P and self.missing[p][o] == 0 and self.splats_in[p]:
            self.at(now + self.lat(o, 0), self.submit, 0, self.report, p)
            p += 1
        self.owner_next[o] = p

    # Rank 0, the dealer
    def open_pass(self, p):
        if p < self.P:
            self.lo[p], self.hi[p], self.left[p] = self.start[:-1], self.start[1:], self.w.tiles
            self.rich[p] = [(self.lo[p][o] - self.hi[p][o], o) for o in range(self.n)]
            heapq.heapify(self.rich[p])

    def richest(self, p):
        """The owner with the most tiles left of p. Each owner has one heap entry, whose key is
        never below its count (counts only fall): a stale top is corrected until it is exact."""
        h, lo, hi = self.rich[p], self.lo[p], self.hi[p]
        while True:
            neg, o = h[0]
            left = hi[o] - lo[o]
            if left == -neg:
                return o
            if left:
                heapq.heapreplace(h, (-left, o))
            else:
                heapq.heappop(h)

    def deal(self, r, want):
        T, out = self.w.tiles, []
        # (at most a rank's share of the two passes in flight, as UnitDealer::grant caps it)
        want = min(want, max(1, 2 * T // self.n))
        passes = [p for p in (self.f, self.f + 1) if p < self.P]
        for p in passes:  # r's own tiles, from the front of its range
            lo, k = self.lo[p], min(want, self.hi[p][r] - self.lo[p][r])
            if k > 0:
                out.extend(range(p * T + lo[r], p * T + lo[r] + k))
                lo[r] += k
                self.left[p] -= k
                want -= k
        for p in passes:  # then others', from the end of the richest owner's range
            while want and self.left[p]:
                o = self.richest(p)
                self.hi[p][o] -= 1
                self.left[p] -= 1
                want -= 1
                out.append(p * T + self.hi[p][o])
        return out

    def grant(self, now, r, want, held):
        units = self.deal(r, want)
        cost = self.cfg.s_req + self.cfg.s_unit * len(units)
        if not units and (not held or self.cfg.empty == "park"):
            self.parked.append((r, want))  # answered when there is work
            return cost
        self.grants += bool(units)
        self.at(now + cost + self.lat(0, r), self.receive, r, units)
        if self.w.splats:
            for u in units:
                self.held[r][u // self.w.tiles] += 1
            cost += self.tell_dealt(now + cost)
        return cost

    def report(self, now, p):
        cost = self.cfg.s_report
        self.reports[p] += 1
        while self.f < self.P and self.reports[self.f] == self.n:
            cost += self.advance(now + cost)
        return cost

    def advance(self, t):
        """Pass f is complete on every owner: tell every rank, open f+2, answer parked asks."""
        f, self.f = self.f, self.f + 1
        self.snaps[f + 1] = self.snap(t)
        self.open_pass(f + 2)
        cost = self.n * self.cfg.s_send
        for r, want in self.parked:
            self.at(t + cost, self.submit, 0, self.grant, r, want, 0)
        self.parked = []
        if f == self.ck_pass:
            self.checkpoint(t + cost)
        return cost

    def checkpoint(self, t):
        """The film through rank 0's link, in the background, then added by its main thread."""
        pix, arrive = self.w.tile_pixels, t
        for o in range(1, self.n):
            arrive = max(arrive, self.send(t, o, 0, PIXEL_BYTES * sum(pix[self.start[o]:self.start[o + 1]])))
        cpu = self.cfg.gather_mp * sum(pix[self.start[1]:]) / 1e6
        self.at(arrive, self.submit, 0, lambda now: cpu)

    # Splats (--estimator bdpt)
    def tell_dealt(self, t):
        cost = 0.0
        for p in (self.f, self.f + 1):
            if p < self.P and self.left[p] == 0 and not self.dealt[p]:
                self.dealt[p] = True
                for r in range(self.n):
                    cost += self.cfg.s_send
                    self.at(t + cost + self.lat(0, r), self.dealt_known, r, p)
        return cost

    def dealt_known(self, now, r, p):
        self.told[r][p] = True
        if self.held[r][p] == 0:
            self.send_splats(now, r, p)

    def send_splats(self, now, r, p):
        n, sends = self.n, self.splat_sends[p]
        nbytes = self.cfg.splat_bytes * self.w.paths[p] / 16 * self.rendered[r][p] * (n - 1) / n
        start = max(now, self.out_free[r])
        self.out_free[r] = start + nbytes / self.cfg.bandwidth
        self.bytes_sent += nbytes
        sends.append((start, self.out_free[r], nbytes / n))
        if len(sends) == n:  # an owner's link takes one share of each sender, in order of sending
            t_in = 0.0
            for begin, _, share in sorted(sends):
                t_in = max(t_in, begin) + share / self.cfg.bandwidth
            t_in = max([t_in] + [end for _, end, _ in sends])
            self.at(t_in + (self.cfg.latency if n > 1 else 0.0), self.splats_arrived, p)

    def splats_arrived(self, now, p):
        self.splats_in[p] = True
        for o in range(self.n):
            self.owner_check(now, o)


def gather_seconds(work, cfg, n):
    """The end: the pixels of every owner but rank 0 through rank 0's link, then added."""
    pixels = sum(work.tile_pixels[work.tiles // n:])
    if n == 1:
        return 0.0
    return PIXEL_BYTES * pixels / cfg.bandwidth + cfg.latency + cfg.gather_mp * pixels / 1e6


def predict(work, cfg, n, speed=None):
    sim = Sim(work, cfg, n, speed).run()
    end = sim.snaps[-1]["t"]
    s0, s1 = sim.snaps[0], sim.snaps[-1]
    if work.extra:  # the span of the steady rate (see the docstring)
        a, b = work.short + 3, len(sim.snaps) - 2
        s0, s1 = sim.snaps[a], sim.snaps[b - (b - a) % 2]
    d = {k: s1[k] - s0[k] for k in s0}
    render = end + (work.extra * work.full_pass * d["t"] / d["work"] if work.extra else 0.0)
    stall, checkpoints = 0.0, 0
    if cfg.checkpoint_every > 0:
        mid = (work.short + len(work.window) - 1) // 2
        stall = max(0.0, Sim(work, cfg, n, speed, mid).run().snaps[-1]["t"] - end)
        checkpoints = int(render / cfg.checkpoint_every)
    gather = gather_seconds(work, cfg, n)
    predicted = render + checkpoints * stall + gather
    capacity = cfg.threads * sum(sim.speed)
    sends = 2 if work.splats else 1
    return dict(nodes=n, threads=cfg.threads, predicted_seconds=predicted,
                ideal_seconds=work.total / capacity, efficiency=work.total / capacity / predicted,
                rank0_busy=d["busy0"] / d["t"], bytes_per_unit=d["bytes"] / d["units"],
                stolen=d["stolen"] / d["units"], idle=1 - d["work"] / (capacity * d["t"]),
                units_per_grant=d["units"] / max(1, d["grants"]), window_seconds=end,
                extrapolated_seconds=render - end, checkpoints=checkpoints,
                checkpoint_stall_seconds=stall, gather_seconds=gather,
                floor_rank0_seconds=work.units * (cfg.s_unit + cfg.s_req / sim.high)
                + work.total_passes * n * (cfg.s_report + sends * cfg.s_send),
                rank0_cpu_seconds=d["busy0"] / d["units"] * work.units,
                floor_window_seconds=work.total / min(n * cfg.threads, 2 * work.tiles))


def self_test():
    fails = []

    def check(name, ok, detail):
        print(f"{'ok  ' if ok else 'FAIL'} {name}: {detail}")
        fails.extend([] if ok else [name])

    free = dict(latency=0.0, bandwidth=math.inf, s_req=0.0, s_unit=0.0, s_add=0.0, s_report=0.0,
                s_send=0.0, gather_mp=0.0)
    cfg = settings(width=512, height=512, spp=256, threads=8, **free)
    e = predict(Work(cfg), cfg, 1)["efficiency"]
    check("one node, no overheads", abs(e - 1) < 0.02, f"efficiency {e:.4f}")
    cfg = settings(width=256, height=256, spp=512, threads=8, t_u=1e-7, **{**free, "s_unit": 1e-5})
    w = Work(cfg)
    ratio = predict(w, cfg, 4)["predicted_seconds"] / (w.units * cfg.s_unit)
    check("rank 0 bound, tiny t_u", 0.97 < ratio < 1.1, f"predicted / (units x s_unit) = {ratio:.3f}")
    cfg = settings(width=1024, height=1024, spp=128, threads=4, t_u=1e-3, **free)
    w = Work(cfg)
    even, slow = predict(w, cfg, 8), predict(w, cfg, 8, [1, 1, 1, 0.25, 1, 1, 1, 1])
    ratio = even["predicted_seconds"] / slow["predicted_seconds"]
    check("stealing: one rank of 8 at 1/4 speed", ratio >= 0.85,
          f"balanced / slowed time {ratio:.3f} (capacity 7.25/8 = 0.906; without stealing 0.25)")
    cfg = settings(width=256, height=256, spp=64, threads=64, **free)
    e = predict(Work(cfg), cfg, 16)["efficiency"]
    check("window bound, N x C = 4T", e <= 0.5 * 1.001, f"efficiency {e:.3f} <= 2T / (N x C) = 0.5")
    cfg = settings(width=512, height=512, spp=1024, threads=8)
    cut, whole = predict(Work(cfg), cfg, 4), predict(Work(settings(**{**vars(cfg), "passes": 99})), cfg, 4)
    ratio = cut["predicted_seconds"] / whole["predicted_seconds"]
    check("window extrapolation", abs(ratio - 1) < 0.03, f"8 of 64 16-path passes simulated / all = {ratio:.4f}")
    check("reproducible", predict(Work(cfg), cfg, 4) == cut, "same seed, same prediction")
    cfg = settings(width=256, height=256, spp=64, threads=8, estimator="bdpt", t_u=1e-3,
                   splat_bytes=1e6, **{**free, "bandwidth": 1e9})
    w = Work(cfg)  # each of 4 owners takes 1/4 of the splats of the 3 other ranks
    floor = cfg.splat_bytes * w.tiles * 64 / 16 / 4 * 3 / 4 / cfg.bandwidth
    r = predict(w, cfg, 4)
    ratio = r["predicted_seconds"] / floor
    check("splats through the owners' links", 1 <= ratio < 2.2, f"predicted / link floor = {ratio:.3f}")
    units = w.tiles * len(w.window)  # all simulated: every unit's splats and every stolen unit's sums
    sent = r["bytes_per_unit"] * units
    due = cfg.splat_bytes * w.tiles * sum(w.paths) / 16 * 3 / 4 + r["stolen"] * units * cfg.bytes_per_unit
    check("bytes conserved", abs(sent / due - 1) < 1e-9, f"sent / due = {sent / due:.12f}")
    print("self-test:", "FAILED: " + ", ".join(fails) if fails else "all passed")
    return 1 if fails else 0


def parse():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--nodes", default="1,10,100,1000", help="N, comma-separated (default %(default)s)")
    ap.add_argument("--empty", choices=["answer", "park"], default="answer",
                    help="a request rank 0 can grant nothing, from a rank that holds units: answered "
                    "at once (it asks again after its next unit) or parked until the pass advances "
                    "(default %(default)s)")
    ap.add_argument("--estimator", choices=["mis", "bdpt"], default="mis",
                    help="bdpt: any estimator whose units splat; mis: any other (default %(default)s)")
    calibrated = set(CALIBRATED.values())  # their default: --calibration, else DEFAULTS
    for opt, dest, kind, text in [
            ("--threads", "threads", int, "C, render threads per node"), ("--width", "width", int, ""),
            ("--height", "height", int, ""), ("--spp", "spp", int, ""),
            ("--passes", "passes", int, "K >= 6, 16-path passes simulated"),
            ("--unit-cv", "unit_cv", float, "units' lognormal spread, coefficient of variation"),
            ("--tile-spread", "tile_spread", float, "S: tile cost factors 1/S..S (1: all equal)"),
            ("--seed", "seed", int, ""),
            ("--latency", "latency", float, "seconds of a message, besides its bytes"),
            ("--bandwidth", "bandwidth", float, "bytes/s of each node's link, each way"),
            ("--rank0-seconds-per-report", "s_report", float, "rank 0's CPU per pass report"),
            ("--rank0-seconds-per-send", "s_send", float, "rank 0's CPU per message it sends"),
            ("--checkpoint-every", "checkpoint_every", float, "seconds between checkpoints; 0: none"),
            ("--t-u", "t_u", float, "seconds of a 16-path unit on one thread"),
            ("--rank0-seconds-per-request", "s_req", float, "rank 0's CPU per request"),
            ("--rank0-seconds-per-unit", "s_unit", float, "rank 0's CPU per unit granted"),
            ("--bytes-per-unit", "bytes_per_unit", float, "a stolen unit's sums"),
            ("--splat-bytes-per-unit", "splat_bytes", float, "of a 16-path unit; bdpt needs it"),
            ("--owner-add-seconds", "s_add", float, "owner's CPU per unit received"),
            ("--gather-seconds-per-megapixel", "gather_mp", float, "rank 0's CPU to add a gathered megapixel")]:
        default = f"--calibration, else {DEFAULTS[dest]}" if dest in calibrated else "%(default)s"
        unit = "BYTES" if "bytes" in dest else "SECONDS" if kind is float and "seconds" in opt else None
        ap.add_argument(opt, dest=dest, type=kind, default=None if dest in calibrated else DEFAULTS[dest],
                        metavar=unit or dest.upper(), help=f"{text} (default {default})".lstrip())
    ap.add_argument("--calibration", help="JSON object with any of: " + ", ".join(CALIBRATED))
    ap.add_argument("--json", help="write the settings and every figure to this file")
    ap.add_argument("--self-test", action="store_true", help="run the internal checks and exit")
    a = ap.parse_args()
    calibration = json.load(open(a.calibration)) if a.calibration else {}
    unknown = set(calibration) - set(CALIBRATED) - {"source"}  # ("source": where it was measured)
    if unknown:
        ap.error(f"unknown calibration keys: {', '.join(sorted(unknown))}")
    for key, dest in CALIBRATED.items():  # the command line, then the calibration, then DEFAULTS
        if getattr(a, dest) is None:
            setattr(a, dest, calibration.get(key, DEFAULTS[dest]))
    if a.estimator == "bdpt" and a.splat_bytes is None:
        ap.error("--estimator bdpt needs --splat-bytes-per-unit (or splat_bytes_per_unit in --calibration)")
    if a.passes < 6:
        ap.error("--passes must be at least 6")
    return a


def main():
    a = parse()
    if a.self_test:
        return self_test()
    cfg = settings(**{k: v for k, v in vars(a).items() if k in DEFAULTS})
    work = Work(cfg)
    print(f"{cfg.width} x {cfg.height}, {cfg.spp} spp, {cfg.estimator}: {work.tiles} tiles x {work.total_passes} "
          f"passes = {work.units:,} units; t_u {cfg.t_u * 1e3:g} ms; C = {cfg.threads} threads per node")
    print(f"Simulated: {len(work.window)} passes ({work.short} of fewer than 16 paths, then 16-path ones, the last "
          f"being the render's last); the other {work.extra} are extrapolated at the steady time per pass.\n"
          "Floors: rank 0 analytic / rank 0 CPU simulated: rank 0's main thread for all units; window: "
          "the work over min(N x C, 2T) threads; gather: the film to rank 0 at the end.\n")
    head = ("nodes", "predicted s", "ideal s", "efficiency", "rank 0 busy", "bytes/unit", "stolen", "idle",
            "floor rank 0 s", "rank 0 CPU s", "floor window s", "gather s", "run s")
    print("| " + " | ".join(head) + " |\n|" + "---|" * len(head))
    rows = []
    for n in [int(x) for x in a.nodes.split(",")]:
        if n > work.tiles:
            print(f"| {n} | more nodes than tiles: skipped |")
            continue
        t0 = time.time()
        r = predict(work, cfg, n)
        r["run_seconds"] = time.time() - t0
        rows.append(r)
        print(f"| {n} | {r['predicted_seconds']:.4g} | {r['ideal_seconds']:.4g} | {r['efficiency']:.1%} | "
              f"{r['rank0_busy']:.1%} | {r['bytes_per_unit']:,.0f} | {r['stolen']:.1%} | {r['idle']:.1%} | "
              f"{r['floor_rank0_seconds']:.3g} | {r['rank0_cpu_seconds']:.3g} | {r['floor_window_seconds']:.3g} | "
              f"{r['gather_seconds']:.3g} | {r['run_seconds']:.1f} |", flush=True)
    if a.json:
        benchlib.write_json(a.json, {"settings": vars(cfg), "total_passes": work.total_passes,
                                     "simulated_passes": len(work.window),
                                     "extrapolated_passes": work.extra, "units": work.units,
                                     "rows": rows}, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
