"""skillbank's own satisficing planner: grounding by relaxed reachability, then greedy best-first with h_ff.

The STRIPS subset skillbank writes (typed objects, conjunctive preconditions
of positive and negative literals, add and delete effects, a conjunctive goal)
is grounded only where it can matter:

- a *static* predicate (in no action's effect) is a lookup against ``:init``
  while the parameters are bound, so ``(next ?b ?n)`` binds ``?n`` from the
  initial facts instead of trying every pair of objects;
- an action is grounded only once its positive preconditions are reachable
  when deletes are ignored (a semi-naive fixpoint: each new fact is joined
  with the facts reached before it).

Negative preconditions are compiled into complement facts (positive normal
form), so the search and the heuristic see plain STRIPS. The search is lazy
greedy best-first search with the FF heuristic (a relaxed plan extracted from
the relaxed planning graph), helpful actions tried first, duplicate detection
and ties broken by insertion order, so the same problem always gives the same
plan; the plan found is then shortened by action elimination. It is not
optimal: ``search="optimal"`` (A* with LM-cut, jupyddl) is.
"""

from __future__ import annotations

import heapq
import time
from itertools import product

import numpy as np

from ._pddl import _check_name, _typed_list, atoms_of, format_sexpr, parse_domain, parse_sexpr

__all__ = ["Grounded", "ground", "search", "eliminate", "valid", "SearchFailed"]

#: Above this many precondition entries the relaxed planning graph is built with numpy, a layer at a time
#: (a few large array passes); below it a Python loop touching each entry once is faster.
_NUMPY_ENTRIES = 20_000
#: Ground actions built between two looks at the clock.
_CLOCK_EVERY = 2048


class SearchFailed(Exception):
    """The search ended without a plan: ``reason`` is ``"expansions"``, ``"time"``, ``"exhausted"`` or
    ``"groundings"`` (more reachable ground actions than the bound)."""

    def __init__(self, reason: str, expanded: int):
        super().__init__(reason)
        self.reason, self.expanded = reason, expanded


def _refused(detail: str) -> ValueError:
    return ValueError(f"planner: the PDDL was refused: {' '.join(str(detail).split())[:160]} (the "
                      "satisficing search reads STRIPS; search='optimal' reads more)")


def _fact_name(fact) -> str:
    pred, args = fact
    return "(" + " ".join((pred, *args)) + ")"


class _Index:
    """Facts by predicate, with lookups by the values of some argument positions (built when first asked)."""

    def __init__(self):
        self.facts: dict = {}
        self.maps: dict = {}

    def add(self, pred, args):
        self.facts.setdefault(pred, []).append(args)
        for (p, positions), table in self.maps.items():
            if p == pred:
                table.setdefault(tuple(args[k] for k in positions), []).append(args)

    def match(self, pred, pattern):
        positions = tuple(k for k, v in enumerate(pattern) if v is not None)
        if not positions:
            return self.facts.get(pred, ())
        key = (pred, positions)
        table = self.maps.get(key)
        if table is None:
            table = {}
            for args in self.facts.get(pred, ()):
                table.setdefault(tuple(args[k] for k in positions), []).append(args)
            self.maps[key] = table
        return table.get(tuple(pattern[k] for k in positions), ())


class _Schema:
    """An action schema split for grounding: static and fluent literals, effects as templates."""

    def __init__(self, action, static, allowed):
        self.name = action.name
        self.params = [p for p, _ in action.parameters]
        self.allowed = {p: allowed(t) for p, t in action.parameters}
        self.choices = {p: sorted(v) for p, v in self.allowed.items()}
        self.constants = {a: a for _, _, args in action.atoms() for a in args if a[0] != "?"}
        pre = atoms_of(action.precondition, f"action {action.name} precondition")
        eff = atoms_of(action.effect, f"action {action.name} effect")
        self.pos = [(p, a) for neg, p, a in pre if not neg]
        self.neg_static = [(p, a) for neg, p, a in pre if neg and p in static]
        self.neg_fluent = [(p, a) for neg, p, a in pre if neg and p not in static]
        self.fluent = [(p, a) for p, a in self.pos if p not in static]
        #: each positive fluent literal (as a trigger: the fact just reached) and the literals left to join
        self.triggers = [(self.pos[j], self.pos[:j] + self.pos[j + 1:]) for j in range(len(self.pos))
                         if self.pos[j][0] not in static]
        self.add = [(p, a) for neg, p, a in eff if not neg]
        self.delete = [(p, a) for neg, p, a in eff if neg]


def _ground_args(args, binding):
    return tuple(map(binding.__getitem__, args))  # constants map to themselves in a full binding


def _join(literals, binding, index, allowed):
    """Every extension of ``binding`` under which all ``literals`` are facts of ``index``."""
    if not literals:
        yield binding
        return
    best = max(range(len(literals)),  # most bound arguments first: the narrowest lookup
               key=lambda i: (sum(1 for a in literals[i][1] if a[0] != "?" or a in binding), -i))
    pred, args = literals[best]
    rest = literals[:best] + literals[best + 1:]
    pattern = tuple(binding.get(a) if a[0] == "?" else a for a in args)
    for values in index.match(pred, pattern):
        if len(values) != len(args):
            continue
        extended = binding
        for a, v in zip(args, values, strict=True):
            if a[0] != "?":
                if a != v:
                    break
                continue
            bound = extended.get(a)
            if bound is None:
                if v not in allowed[a]:
                    break
                if extended is binding:
                    extended = dict(binding)
                extended[a] = v
            elif bound != v:
                break
        else:
            yield from _join(rest, extended, index, allowed)


class Grounded:
    """A ground STRIPS task in positive normal form: integer facts, operators as lists of fact ids.

    Attributes
    ----------
    facts : list of str
        Fact names, ``"(pressed b1)"``; a complement reads ``"(not (pressed b1))"``.
    init : int
        The initial state as a bitmask of fact ids.
    goal : list of int
    names : list of (str, tuple)
        Each operator's action and arguments.
    pre, add, delete : list of list of int
    unreachable : list of str
        Goal facts no sequence of actions makes true (deletes ignored), sorted.
    """

    def __init__(self, facts, init, goal, names, pre, add, delete, unreachable):
        self.facts, self.init, self.goal = facts, init, goal
        self.names, self.pre, self.add, self.delete = names, pre, add, delete
        self.unreachable = unreachable
        self._masks: dict = {}
        self.goal_mask = _mask(goal)
        n_ops, n_facts = len(names), len(facts)
        self.n_pre = [len(p) for p in pre]
        self.zero_pre = [o for o in range(n_ops) if not pre[o]]
        self.pre_of: list = [[] for _ in range(n_facts)]
        for o, p in enumerate(pre):
            for f in p:
                self.pre_of[f].append(o)
        self.goal_set = frozenset(goal)
        self.entries = sum(self.n_pre)
        if self.entries > _NUMPY_ENTRIES:
            self.pre_op = np.repeat(np.arange(n_ops), self.n_pre)
            self.pre_fact = np.fromiter((f for p in pre for f in p), dtype=np.int64, count=self.entries)
            self.n_pre_arr = np.asarray(self.n_pre, dtype=float)
            n_add = [len(a) for a in add]
            self.add_op = np.repeat(np.arange(n_ops), n_add)
            self.add_fact = np.fromiter((f for a in add for f in a), dtype=np.int64, count=sum(n_add))
            self.goal_arr = np.asarray(goal, dtype=np.int64)

    def masks(self, op):
        """``(pre, add, delete)`` bitmasks of an operator (built when first used)."""
        m = self._masks.get(op)
        if m is None:
            m = self._masks[op] = (_mask(self.pre[op]), _mask(self.add[op]), _mask(self.delete[op]))
        return m

    def true_facts(self, state: int) -> list:
        """The fact ids set in ``state``."""
        n = len(self.facts)
        raw = np.frombuffer(state.to_bytes((n + 7) // 8 or 1, "little"), dtype=np.uint8)
        return np.flatnonzero(np.unpackbits(raw, bitorder="little")[:n]).tolist()

    def graph(self, state: int, *, stop_at_goal: bool = True):
        """The relaxed planning graph from ``state``: ``(level, achiever, applicable)``.

        ``level[f]`` is the first layer of fact ``f`` (-1: not reached),
        ``achiever[f]`` the lowest-numbered operator of the layer before that
        adds it, ``applicable`` the operators applicable in ``state``, sorted.
        """
        true = self.true_facts(state)
        if self.entries > _NUMPY_ENTRIES:
            return self._graph_numpy(true, stop_at_goal)
        return self._graph_python(true, stop_at_goal)

    def _graph_python(self, true, stop_at_goal):
        level = [-1] * len(self.facts)
        achiever = {}
        remaining = self.n_pre[:]
        pre_of, add, goal_set = self.pre_of, self.add, self.goal_set
        for f in true:
            level[f] = 0
        goals_left = sum(1 for g in self.goal if level[g] < 0)
        ops = list(self.zero_pre)
        new, layer, applicable = true, 0, None
        while True:
            for f in new:
                for o in pre_of[f]:
                    remaining[o] -= 1
                    if remaining[o] == 0:
                        ops.append(o)
            ops.sort()
            if applicable is None:
                applicable = ops[:]
            if not ops or (stop_at_goal and not goals_left):
                break
            new = []
            for o in ops:
                for f in add[o]:
                    if level[f] < 0:
                        level[f] = layer + 1
                        achiever[f] = o
                        new.append(f)
                        if f in goal_set:
                            goals_left -= 1
            ops, layer = [], layer + 1
            if not new:
                break
        return level, achiever, applicable

    def _graph_numpy(self, true, stop_at_goal):
        n_facts, n_ops = len(self.facts), len(self.names)
        reached = np.zeros(n_facts, dtype=bool)
        reached[true] = True
        level = np.where(reached, 0, -1)
        achiever = np.full(n_facts, -1, dtype=np.int64)
        done = np.zeros(n_ops, dtype=bool)
        layer, applicable = 0, None
        while True:
            count = np.bincount(self.pre_op, weights=reached[self.pre_fact], minlength=n_ops)
            fresh = (count == self.n_pre_arr) & ~done
            if applicable is None:
                applicable = np.flatnonzero(fresh).tolist()
            if not fresh.any() or (stop_at_goal and reached[self.goal_arr].all()):
                break
            done |= fresh
            chosen = fresh[self.add_op]
            facts, ops = self.add_fact[chosen], self.add_op[chosen]
            new = ~reached[facts]
            facts, ops = facts[new], ops[new]
            if not facts.size:
                break
            # add entries are in operator order: the first of each fact is its lowest-numbered achiever
            unique, first = np.unique(facts, return_index=True)
            achiever[unique] = ops[first]
            reached[unique] = True
            level[unique] = layer + 1
            layer += 1
        return level.tolist(), achiever.tolist(), applicable

    def evaluate(self, state: int):
        """``(h_ff, preferred, applicable)`` of ``state``; h is None when the goal is unreachable from it."""
        level, achiever, applicable = self.graph(state)
        buckets: dict = {}
        for g in self.goal:
            if level[g] < 0:
                return None, (), applicable
            if level[g] > 0:
                buckets.setdefault(level[g], []).append(g)
        chosen, marked, preferred = set(), set(), []
        pre, add = self.pre, self.add
        for lev in range(max(buckets, default=0), 0, -1):
            for g in buckets.get(lev, ()):  # a layer's bucket grows only while higher layers are read
                if g in marked:
                    continue
                op = achiever[g]
                if op in chosen:
                    continue
                chosen.add(op)
                if lev == 1:
                    preferred.append(op)
                marked.update(add[op])
                for p in pre[op]:
                    if level[p] > 0 and p not in marked:
                        buckets.setdefault(level[p], []).append(p)
        return len(chosen), preferred, applicable


def _mask(ids) -> int:
    m = 0
    for f in ids:
        m |= 1 << f
    return m


def _parents(expr) -> dict:
    for part in expr[2:]:
        if isinstance(part, list) and part[:1] == [":types"]:
            return dict(_typed_list(part[1:], "domain :types", variables=False))
    return {}


def _section(expr, key):
    for part in expr[2:]:
        if isinstance(part, list) and part[:1] == [key]:
            return part
    return None


def _ground_atoms(items, where):
    out = []
    for item in items:
        if isinstance(item, str) or not item or any(not isinstance(a, str) for a in item) \
                or any(a.startswith("?") for a in item):
            raise ValueError(f"{where}: expected ground atoms (predicate object ...), got "
                             f"{_show(item)}")
        out.append((_check_name(item[0], "a predicate name", where), tuple(item[1:])))
    return out


def _show(item) -> str:
    text = format_sexpr(item)
    return text if len(text) <= 40 else text[:37] + "..."


def _goal(expr):
    """``[(negated, fact)]`` of a goal: an atom, ``(not ATOM)`` or ``(and ...)`` of those."""
    if isinstance(expr, str):
        raise ValueError(f"goal: expected (and ATOM ...), got {expr!r}")
    items = expr[1:] if expr[:1] == ["and"] else [expr]
    out = []
    for item in items:
        negated = isinstance(item, list) and item[:1] == ["not"] and len(item) == 2
        atom = item[1] if negated else item
        out += [(negated, fact) for fact in _ground_atoms([atom], "goal")]
    return out


def _read(domain: str, problem: str):
    # the requirements declared are not checked: the reader refuses what lies outside STRIPS, and a
    # domain that declares more than it uses is planned
    dom = parse_domain(domain, "domain")
    dexpr = parse_sexpr(domain, "domain")
    pexpr = parse_sexpr(problem, "problem")
    if not isinstance(pexpr, list) or pexpr[:1] != ["define"] or len(pexpr) < 2 \
            or not isinstance(pexpr[1], list) or pexpr[1][:1] != ["problem"]:
        raise ValueError(f"problem: expected (define (problem NAME) ...), got {_show(pexpr)}")
    objects = {}
    const = _section(dexpr, ":constants")
    if const is not None:
        objects.update(_typed_list(const[1:], "domain :constants", variables=False))
    init, goal = [], []
    for part in pexpr[2:]:
        if isinstance(part, str) or not part:
            raise ValueError(f"problem: expected (:section ...), got {_show(part)}")
        head = part[0]
        if head == ":objects":
            objects.update(_typed_list(part[1:], "problem :objects", variables=False))
        elif head == ":init":
            init = _ground_atoms(part[1:], "init")
        elif head == ":goal":
            if len(part) != 2:
                raise ValueError(f"goal: expected one expression, got {len(part) - 1}")
            goal = _goal(part[1])
        elif head not in (":domain", ":requirements"):
            raise ValueError(f"problem: expected :domain, :objects, :init and :goal sections (STRIPS), got "
                             f"{_show(head)}")
    return dom, _parents(dexpr), objects, init, goal


def _typing(parents, objects):
    """``allowed(type)``: the set of objects whose type is ``type`` or a descendant of it."""
    cache: dict = {}

    def ancestors(kind):
        seen = []
        while kind not in seen:  # a cycle in a bad domain ends the walk
            seen.append(kind)
            kind = parents.get(kind, "object")
        return seen

    by_type: dict = {}
    for name, kind in objects.items():
        for t in ancestors(kind):
            by_type.setdefault(t, set()).add(name)

    def allowed(kind):
        if kind not in cache:
            cache[kind] = frozenset(objects) if kind == "object" else frozenset(by_type.get(kind, ()))
        return cache[kind]

    return allowed


def ground(domain: str, problem: str, *, deadline: float | None = None,
           max_groundings: int | None = None) -> Grounded:
    """Ground the STRIPS ``domain`` and ``problem`` (PDDL text) where relaxed reachability allows.

    Raises ValueError (one line, ``"planner: the PDDL was refused: ..."``) on
    text outside the subset, and :class:`SearchFailed` past ``deadline``
    (a :func:`time.perf_counter` value) or when more than ``max_groundings``
    ground actions are reachable (``reason`` ``"groundings"``).

    Examples
    --------
    >>> d = ("(define (domain d) (:requirements :strips :typing) (:types button) "
    ...      "(:action press :parameters (?b - button) :effect (pressed ?b)))")
    >>> p = "(define (problem p) (:domain d) (:objects b1 b2 - button) (:init) (:goal (pressed b2)))"
    >>> g = ground(d, p)
    >>> g.names, g.facts
    ([('press', ('b1',)), ('press', ('b2',))], ['(pressed b1)', '(pressed b2)'])
    """
    try:
        dom, parents, objects, init, goal = _read(domain, problem)
        static, schemas = _schemas(dom, parents, objects)
    except (ValueError, RecursionError) as exc:
        raise _refused(exc) from None
    index = _Index()
    static_init = set()
    queue, queued = [], set()
    for fact in dict.fromkeys(init):  # in order, once each
        if fact[0] in static:
            static_init.add(fact)
            index.add(*fact)
        else:
            queued.add(fact)
            queue.append(fact)
    triggers: dict = {}
    for s in schemas:
        for literal, rest in s.triggers:
            triggers.setdefault(literal[0], []).append((s, literal[1], rest))
    raw, seen = [], set()

    def instantiate(s, binding):
        free = [p for p in s.params if p not in binding]
        for values in product(*(s.choices[p] for p in free)):
            full = dict(binding)
            full.update(zip(free, values, strict=True))
            full.update(s.constants)
            objs = tuple(full[p] for p in s.params)
            key = (s.name, objs)
            if key in seen:
                continue
            seen.add(key)
            if any((p, _ground_args(a, full)) in static_init for p, a in s.neg_static):
                continue
            if deadline is not None and len(seen) % _CLOCK_EVERY == 0 and time.perf_counter() > deadline:
                raise SearchFailed("time", 0)
            adds = [(p, _ground_args(a, full)) for p, a in s.add]
            if max_groundings is not None and len(raw) >= max_groundings:
                raise SearchFailed("groundings", 0)
            raw.append((key, [(p, _ground_args(a, full)) for p, a in s.fluent],
                        [(p, _ground_args(a, full)) for p, a in s.neg_fluent], adds,
                        [(p, _ground_args(a, full)) for p, a in s.delete]))
            for fact in adds:
                if fact not in queued:
                    queued.add(fact)
                    queue.append(fact)

    for s in schemas:
        if not s.triggers:  # no fluent precondition: grounded once, from the static facts
            for binding in _join(s.pos, {}, index, s.allowed):
                instantiate(s, binding)
    head = 0
    while head < len(queue):  # semi-naive: each fact reached is joined with those reached before it
        fact = queue[head]
        head += 1
        index.add(*fact)
        pred, values = fact
        for s, args, rest in triggers.get(pred, ()):
            binding = _unify(args, values, s.allowed)
            if binding is not None:
                for b in _join(rest, binding, index, s.allowed):
                    instantiate(s, b)
    return _finish(queue, set(init), static_init, static, goal, raw)


def _unify(args, values, allowed):
    """The binding under which the literal's ``args`` read ``values`` (None when none does)."""
    if len(args) != len(values):
        return None
    binding = {}
    for a, v in zip(args, values, strict=True):
        if a[0] != "?":
            if a != v:
                return None
        elif binding.setdefault(a, v) != v or v not in allowed[a]:
            return None
    return binding


def _schemas(dom, parents, objects):
    """The static predicates (in no action's effect) and the action schemas split for grounding."""
    allowed = _typing(parents, objects)
    acts = list(dom.actions.values())
    used = {p for a in acts for _, p, _ in atoms_of(a.precondition, f"action {a.name} precondition")}
    changed = {p for a in acts for _, p, _ in atoms_of(a.effect, f"action {a.name} effect")}
    static = frozenset(used - changed)
    return static, [_Schema(a, static, allowed) for a in acts]


def _finish(reached, init_set, static_init, static, goal, raw) -> Grounded:
    """Number the reached facts, compile negative literals into complements, keep the reachable operators."""
    ids = {fact: k for k, fact in enumerate(reached)}
    names = [_fact_name(f) for f in reached]
    negated = {f for _, _, neg, _, _ in raw for f in neg if f in ids}
    negated |= {f for neg, f in goal if neg and f in ids}
    comp = {}
    for fact in sorted(negated, key=ids.get):
        comp[fact] = len(names)
        names.append(f"(not {_fact_name(fact)})")
    init_ids = [ids[f] for f in reached if f in init_set] + [comp[f] for f in comp if f not in init_set]
    goal_ids, unreachable = [], []
    for neg, fact in goal:
        name = f"(not {_fact_name(fact)})" if neg else _fact_name(fact)
        if fact[0] in static:  # a lookup: it holds from the start or never
            if (fact in static_init) == neg:
                unreachable.append(name)
        elif fact not in ids:  # never true: its negation always holds
            if not neg:
                unreachable.append(name)
        else:
            goal_ids.append(comp[fact] if neg else ids[fact])
    ops, pre, add, delete = [], [], [], []
    get = ids.__getitem__
    for key, pos, neg, adds, dels in raw:
        ops.append(key)
        if comp:
            added = set(adds)  # an atom both added and deleted is added (deletes apply first)
            p = {get(f) for f in pos} | {comp[f] for f in neg if f in comp}
            a = {get(f) for f in adds} | {comp[f] for f in dels if f in comp and f not in added}
            d = {ids[f] for f in dels if f in ids and f not in added} | {comp[f] for f in adds if f in comp}
        else:
            p, a = set(map(get, pos)), set(map(get, adds))
            d = {ids[f] for f in dels if f in ids}
        pre.append(sorted(p))
        add.append(sorted(a))
        delete.append(sorted(d - a))
    task = Grounded(names, _mask(init_ids), sorted(set(goal_ids)), ops, pre, add, delete, [])
    # complements make reachability exact for negative literals: a second pass, deletes still ignored
    level, _, _ = task.graph(task.init, stop_at_goal=False)
    unreachable += [names[g] for g in task.goal if level[g] < 0]
    keep = [o for o in range(len(ops)) if all(level[f] >= 0 for f in pre[o])]
    if len(keep) < len(ops):
        task = Grounded(names, task.init, task.goal, [ops[o] for o in keep], [pre[o] for o in keep],
                        [add[o] for o in keep], [delete[o] for o in keep], [])
    task.unreachable = sorted(unreachable)
    return task


def search(task: Grounded, *, max_expansions: int, deadline: float) -> tuple:
    """Lazy greedy best-first search with h_ff: ``(plan as operator ids, states expanded)``.

    A state is evaluated when it is taken from the queue; its successors
    enter with its h, helpful actions (the relaxed plan's first layer) before
    the others, ties in insertion order. Raises :class:`SearchFailed`.
    """
    init = task.init
    goal = task.goal_mask
    states = {init: None}  # state -> (parent state, operator)
    heap: list = []
    counter = 0
    expanded = 0
    state = init
    while True:
        if state & goal == goal:
            plan = []
            while states[state] is not None:
                state, op = states[state]
                plan.append(op)
            return plan[::-1], expanded
        if expanded >= max_expansions:
            raise SearchFailed("expansions", expanded)
        if time.perf_counter() > deadline:
            raise SearchFailed("time", expanded)
        h, preferred, applicable = task.evaluate(state)
        expanded += 1
        if h is not None:
            helpful = set(preferred)
            for op in applicable:
                heapq.heappush(heap, (h, op not in helpful, counter, state, op))
                counter += 1
        while True:
            if not heap:
                raise SearchFailed("exhausted", expanded)
            _, _, _, parent, op = heapq.heappop(heap)
            _, a, d = task.masks(op)
            child = (parent & ~d) | a
            if child not in states:
                states[child] = (parent, op)
                state = child
                break


def valid(task: Grounded, plan) -> bool:
    """Whether ``plan`` (operator ids) is applicable from the initial state and ends in the goal."""
    state = task.init
    for op in plan:
        p, a, d = task.masks(op)
        if state & p != p:
            return False
        state = (state & ~d) | a
    return state & task.goal_mask == task.goal_mask


def eliminate(task: Grounded, plan) -> list:
    """Action elimination: drop an action and any later one that loses its precondition, while the goal holds.

    Examples
    --------
    >>> d = ("(define (domain d) (:requirements :strips) "
    ...      "(:action a :parameters (?x) :effect (p ?x)))")
    >>> g = ground(d, "(define (problem q) (:domain d) (:objects x y) (:init) (:goal (p x)))")
    >>> [g.names[o] for o in eliminate(g, [1, 0])]
    [('a', ('x',))]
    """
    plan = list(plan)
    k = 0
    while k < len(plan):
        state, kept = task.init, []
        for j, op in enumerate(plan):
            if j == k:
                continue
            p, a, d = task.masks(op)
            if j > k and state & p != p:
                continue  # made useless by the removal: goes too
            state = (state & ~d) | a
            kept.append(op)
        if state & task.goal_mask == task.goal_mask and len(kept) < len(plan):
            plan = kept
        else:
            k += 1
    return plan
