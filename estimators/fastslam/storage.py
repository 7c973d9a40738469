"""Landmark maps of M particles that share what they have in common: persistent copy-on-write trees.

Each particle's map is an F-ary tree of depth D (inner levels) whose leaves hold B landmark slots.
Slot s lives in leaf ``s // B`` at offset ``s % B``; the leaf's index, written in base F with D
digits (most significant first), is the path from the root. A slot holds the landmark's mean μ (2,),
its covariance Σ as (σxx, σxy, σyy), a state: 0 for an empty or removed slot, k ≥ 1 for a live
landmark (its existence counter), and its sightings and birth time (the tentative-landmark rule of
:mod:`.kernels`).

Nodes are reference counted and shared between particles. Resampling only copies roots
(``resample``: O(M)); writing a slot copies the nodes on its path that are shared (path copying:
O(D·F + B) = O(log n) per write), so a particle's write is never seen by another particle. A node
whose count drops to zero returns to a free list, with the counts of its children decremented
(iteratively, with an explicit stack). When a slot beyond the capacity F^D·B is written, every
particle gets a new root one level up (D grows by one).

Pools (numba kernels below; the class grows them in Python before a kernel could run out):

    inner_child (Ni, F) int32   child node (inner node, or leaf at the last inner level); −1 none
    inner_ref   (Ni,)   int32   references (0: free)
    leaf_mu     (Nl, B, 2)      landmark means [m]
    leaf_S      (Nl, B, 3)      covariances (σxx, σxy, σyy) [m²]
    leaf_state  (Nl, B) int32   0 empty/removed, ≥ 1 live (existence counter)
    leaf_seen   (Nl, B) int32   sightings since the landmark was started (the starting one included)
    leaf_born   (Nl, B)         time the landmark was started [s]
    leaf_ref    (Nl,)   int32
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["LandmarkStore", "FANOUT", "LEAF"]

FANOUT = 16  # children of an inner node
LEAF = 16  # landmark slots of a leaf


@njit(cache=True)
def _alloc(free, top, used, cap):
    """A node index: from the free stack (``top[0]`` entries) or the next never-used one; −1 when full."""
    if top[0] > 0:
        top[0] -= 1
        return free[top[0]]
    if used[0] < cap:
        used[0] += 1
        return used[0] - 1
    return -1


@njit(cache=True)
def _release(
    node, level, depth, inner_child, inner_ref, leaf_ref, free_inner, top_inner, free_leaf, top_leaf, stack_n, stack_l
):
    """Drop one reference to ``node`` at ``level`` (level == depth: a leaf); free what reaches zero."""
    sp = 0
    stack_n[0] = node
    stack_l[0] = level
    sp = 1
    while sp > 0:
        sp -= 1
        n = stack_n[sp]
        lv = stack_l[sp]
        if lv == depth:
            leaf_ref[n] -= 1
            if leaf_ref[n] == 0:
                free_leaf[top_leaf[0]] = n
                top_leaf[0] += 1
            continue
        inner_ref[n] -= 1
        if inner_ref[n] == 0:
            for c in range(inner_child.shape[1]):
                child = inner_child[n, c]
                if child >= 0:
                    stack_n[sp] = child
                    stack_l[sp] = lv + 1
                    sp += 1
                    inner_child[n, c] = -1
            free_inner[top_inner[0]] = n
            top_inner[0] += 1


@njit(cache=True)
def find(root, slot, depth, inner_child):
    """(leaf, offset) of ``slot`` in the tree at ``root``; leaf −1 when the path does not exist."""
    leaf_index = slot // LEAF
    node = root
    for level in range(depth):
        digit = (leaf_index // FANOUT ** (depth - 1 - level)) % FANOUT
        node = inner_child[node, digit]
        if node < 0:
            return -1, 0
    return node, slot % LEAF


@njit(cache=True)
def writable(
    m,
    slot,
    depth,
    roots,
    inner_child,
    inner_ref,
    leaf_mu,
    leaf_S,
    leaf_state,
    leaf_seen,
    leaf_born,
    leaf_ref,
    free_inner,
    top_inner,
    used_inner,
    free_leaf,
    top_leaf,
    used_leaf,
):
    """(leaf, offset) of ``slot`` in particle m's tree, made private to m: every shared node on the path
    is copied (path copying), missing nodes are created. The caller writes the slot in place."""
    cap_inner = inner_child.shape[0]
    cap_leaf = leaf_mu.shape[0]
    node = roots[m]
    if inner_ref[node] > 1:  # a shared root: copy it
        new = _alloc(free_inner, top_inner, used_inner, cap_inner)
        for c in range(FANOUT):
            child = inner_child[node, c]
            inner_child[new, c] = child
            if child >= 0:
                if depth == 1:
                    leaf_ref[child] += 1
                else:
                    inner_ref[child] += 1
        inner_ref[new] = 1
        inner_ref[node] -= 1
        roots[m] = new
        node = new
    leaf_index = slot // LEAF
    for level in range(depth):
        digit = (leaf_index // FANOUT ** (depth - 1 - level)) % FANOUT
        child = inner_child[node, digit]
        last = level == depth - 1
        if child < 0:  # create the missing node
            if last:
                child = _alloc(free_leaf, top_leaf, used_leaf, cap_leaf)
                leaf_state[child, :] = 0
                leaf_ref[child] = 1
            else:
                child = _alloc(free_inner, top_inner, used_inner, cap_inner)
                inner_child[child, :] = -1
                inner_ref[child] = 1
            inner_child[node, digit] = child
        elif last and leaf_ref[child] > 1:  # a shared leaf: copy it
            new = _alloc(free_leaf, top_leaf, used_leaf, cap_leaf)
            leaf_mu[new] = leaf_mu[child]
            leaf_S[new] = leaf_S[child]
            leaf_state[new] = leaf_state[child]
            leaf_seen[new] = leaf_seen[child]
            leaf_born[new] = leaf_born[child]
            leaf_ref[new] = 1
            leaf_ref[child] -= 1
            inner_child[node, digit] = new
            child = new
        elif not last and inner_ref[child] > 1:  # a shared inner node: copy it
            new = _alloc(free_inner, top_inner, used_inner, cap_inner)
            for c in range(FANOUT):
                grandchild = inner_child[child, c]
                inner_child[new, c] = grandchild
                if grandchild >= 0:
                    if level + 1 == depth - 1:
                        leaf_ref[grandchild] += 1
                    else:
                        inner_ref[grandchild] += 1
            inner_ref[new] = 1
            inner_ref[child] -= 1
            inner_child[node, digit] = new
            child = new
        node = child
    return node, slot % LEAF


@njit(cache=True)
def _resample(
    roots,
    ancestors,
    depth,
    inner_child,
    inner_ref,
    leaf_ref,
    free_inner,
    top_inner,
    free_leaf,
    top_leaf,
    stack_n,
    stack_l,
):
    old = roots.copy()
    for m in range(roots.shape[0]):
        roots[m] = old[ancestors[m]]
        inner_ref[roots[m]] += 1
    for m in range(old.shape[0]):
        _release(
            old[m],
            0,
            depth,
            inner_child,
            inner_ref,
            leaf_ref,
            free_inner,
            top_inner,
            free_leaf,
            top_leaf,
            stack_n,
            stack_l,
        )


@njit(cache=True)
def _gather(
    roots, n_slots, depth, inner_child, leaf_mu, leaf_S, leaf_state, leaf_seen, leaf_born, mu, S, state, seen, born
):
    for m in range(roots.shape[0]):
        for s in range(n_slots):
            leaf, off = find(roots[m], s, depth, inner_child)
            if leaf < 0:
                state[m, s] = 0
                continue
            mu[m, s] = leaf_mu[leaf, off]
            S[m, s] = leaf_S[leaf, off]
            state[m, s] = leaf_state[leaf, off]
            seen[m, s] = leaf_seen[leaf, off]
            born[m, s] = leaf_born[leaf, off]


class LandmarkStore:
    """The pools and roots of M particle maps (see the module docstring); grows itself as needed."""

    def __init__(self, particles: int, capacity_hint: int = 64):
        self.M = int(particles)
        self.depth = 1
        n_inner = max(4 * self.M, 64)
        n_leaf = max(4 * self.M, 64)
        self.inner_child = np.full((n_inner, FANOUT), -1, dtype=np.int32)
        self.inner_ref = np.zeros(n_inner, dtype=np.int32)
        self.leaf_mu = np.zeros((n_leaf, LEAF, 2))
        self.leaf_S = np.zeros((n_leaf, LEAF, 3))
        self.leaf_state = np.zeros((n_leaf, LEAF), dtype=np.int32)
        self.leaf_seen = np.zeros((n_leaf, LEAF), dtype=np.int32)
        self.leaf_born = np.zeros((n_leaf, LEAF))
        self.leaf_ref = np.zeros(n_leaf, dtype=np.int32)
        self.free_inner = np.zeros(n_inner, dtype=np.int32)
        self.free_leaf = np.zeros(n_leaf, dtype=np.int32)
        self.top_inner = np.zeros(1, dtype=np.int64)
        self.top_leaf = np.zeros(1, dtype=np.int64)
        self.used_inner = np.zeros(1, dtype=np.int64)
        self.used_leaf = np.zeros(1, dtype=np.int64)
        # one empty root shared by every particle
        self.used_inner[0] = 1
        self.inner_ref[0] = self.M
        self.roots = np.zeros(self.M, dtype=np.int32)
        self._stack = (np.zeros(64, dtype=np.int32), np.zeros(64, dtype=np.int32))

    # ----------------------------------------------------------------- capacity
    @property
    def capacity(self) -> int:
        """Slots a tree of the current depth can address."""
        return FANOUT**self.depth * LEAF

    def live_nodes(self) -> tuple[int, int]:
        """(inner nodes, leaves) in use: allocated minus free."""
        return int(self.used_inner[0] - self.top_inner[0]), int(self.used_leaf[0] - self.top_leaf[0])

    def nbytes(self) -> int:
        """Bytes of the nodes in use (the pools' spare capacity not counted)."""
        inner, leaves = self.live_nodes()
        return inner * (FANOUT * 4 + 4) + leaves * (LEAF * (2 + 3 + 1) * 8 + 2 * LEAF * 4 + 4)

    def reserve(self, slot: int, writes: int) -> None:
        """Make room for ``writes`` path copies and for addressing ``slot`` (grow depth and pools)."""
        while slot >= self.capacity:
            self._grow_depth()
        need_inner = writes * self.depth + self.M
        need_leaf = writes
        self._ensure("inner", need_inner)
        self._ensure("leaf", need_leaf)
        stack = self.used_inner[0] * FANOUT + self.used_leaf[0] + 64
        if self._stack[0].size < stack:
            self._stack = (np.zeros(2 * stack, dtype=np.int32), np.zeros(2 * stack, dtype=np.int32))

    def _ensure(self, kind: str, need: int) -> None:
        if kind == "inner":
            spare = self.inner_child.shape[0] - self.used_inner[0] + self.top_inner[0]
            if spare >= need:
                return
            size = max(2 * self.inner_child.shape[0], int(self.used_inner[0]) + need)
            self.inner_child = _grown(self.inner_child, size, -1)
            self.inner_ref = _grown(self.inner_ref, size, 0)
            self.free_inner = _grown(self.free_inner, size, 0)
        else:
            spare = self.leaf_mu.shape[0] - self.used_leaf[0] + self.top_leaf[0]
            if spare >= need:
                return
            size = max(2 * self.leaf_mu.shape[0], int(self.used_leaf[0]) + need)
            self.leaf_mu = _grown(self.leaf_mu, size, 0.0)
            self.leaf_S = _grown(self.leaf_S, size, 0.0)
            self.leaf_state = _grown(self.leaf_state, size, 0)
            self.leaf_seen = _grown(self.leaf_seen, size, 0)
            self.leaf_born = _grown(self.leaf_born, size, 0.0)
            self.leaf_ref = _grown(self.leaf_ref, size, 0)
            self.free_leaf = _grown(self.free_leaf, size, 0)

    def _grow_depth(self) -> None:
        """One more inner level: each distinct root gets a new parent (its child 0), shared as the root was."""
        self._ensure("inner", self.M)
        old_roots, inverse = np.unique(self.roots, return_inverse=True)
        new_roots = np.empty_like(old_roots)
        for k, old in enumerate(old_roots):
            node = _alloc(self.free_inner, self.top_inner, self.used_inner, self.inner_child.shape[0])
            self.inner_child[node, :] = -1
            self.inner_child[node, 0] = old
            self.inner_ref[node] = self.inner_ref[old]  # the particles that shared the old root share the new one
            self.inner_ref[old] = 1
            new_roots[k] = node
        self.roots = new_roots[inverse].astype(np.int32)
        self.depth += 1

    # ----------------------------------------------------------------- operations
    def resample(self, ancestors: np.ndarray) -> None:
        """Particle m takes the map of particle ``ancestors[m]`` (O(M): roots only)."""
        self.reserve(0, 0)
        _resample(
            self.roots,
            np.ascontiguousarray(ancestors, dtype=np.int64),
            self.depth,
            self.inner_child,
            self.inner_ref,
            self.leaf_ref,
            self.free_inner,
            self.top_inner,
            self.free_leaf,
            self.top_leaf,
            *self._stack,
        )

    def gather(self, n_slots: int, particles=None) -> tuple[np.ndarray, ...]:
        """Slots 0…n−1 of the given particles (default all, P of them): μ (P, n, 2), Σ as (σxx, σxy, σyy)
        (P, n, 3), state (P, n), sightings (P, n), birth time (P, n)."""
        roots = (
            self.roots if particles is None else np.ascontiguousarray(self.roots[np.asarray(particles, dtype=np.int64)])
        )
        mu = np.zeros((roots.size, n_slots, 2))
        S = np.zeros((roots.size, n_slots, 3))
        state = np.zeros((roots.size, n_slots), dtype=np.int32)
        seen = np.zeros((roots.size, n_slots), dtype=np.int32)
        born = np.zeros((roots.size, n_slots))
        _gather(
            roots,
            n_slots,
            self.depth,
            self.inner_child,
            self.leaf_mu,
            self.leaf_S,
            self.leaf_state,
            self.leaf_seen,
            self.leaf_born,
            mu,
            S,
            state,
            seen,
            born,
        )
        return mu, S, state, seen, born

    def kernel_args(self) -> tuple:
        """The pools in the order the update kernels take them."""
        return (
            self.roots,
            self.inner_child,
            self.inner_ref,
            self.leaf_mu,
            self.leaf_S,
            self.leaf_state,
            self.leaf_seen,
            self.leaf_born,
            self.leaf_ref,
            self.free_inner,
            self.top_inner,
            self.used_inner,
            self.free_leaf,
            self.top_leaf,
            self.used_leaf,
        )


def _grown(a: np.ndarray, size: int, fill) -> np.ndarray:
    out = np.full((size,) + a.shape[1:], fill, dtype=a.dtype)
    out[: a.shape[0]] = a
    return out
