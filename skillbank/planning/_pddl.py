"""The PDDL text skillbank reads and writes: action schemas, domains, problems and atoms.

A small reader of the STRIPS subset with typing and negative preconditions
(what a skill's action schema needs), so that descriptions are checked when
they are stored and a domain and problem can be written as plain PDDL files
that any planner reads. Names are case-insensitive in PDDL: they are read in
lower case.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ._json import describe

__all__ = ["Action", "Domain", "parse_sexpr", "parse_action", "parse_domain", "parse_atom", "format_sexpr",
           "domain_text", "problem_text", "atoms_of"]

_CONNECTIVES = ("and", "not")
#: Deepest nesting of parentheses read. A STRIPS domain needs 5 ((define (:action :effect (and (not (p)))))):
#: the bound is far above that and far below what a recursive reader (skillbank's own, or the planner's)
#: could take.
MAX_PDDL_DEPTH = 32
_NAME_CHARS = set("abcdefghijklmnopqrstuvwxyz0123456789-_")
#: PDDL's logical words: a predicate of one of these names would be read as the connective by a planner.
_RESERVED = frozenset({"and", "or", "not", "imply", "forall", "exists", "when", "either", "define", "domain",
                       "problem"})


def _tokens(text: str, name: str) -> list:
    out = []
    for line in text.splitlines():
        line = line.split(";", 1)[0]  # PDDL comments run to the end of the line
        out += line.replace("(", " ( ").replace(")", " ) ").split()
    if not out:
        raise ValueError(f"{name}: expected PDDL text, got none")
    return [t.lower() for t in out]


def parse_sexpr(text: str, name: str = "pddl"):
    """One parenthesised PDDL expression as nested lists of lower-case strings.

    Examples
    --------
    >>> parse_sexpr("(and (free ?b) (not (Pressed ?b)))")
    ['and', ['free', '?b'], ['not', ['pressed', '?b']]]
    >>> parse_sexpr("(free ?b")
    Traceback (most recent call last):
    ...
    ValueError: pddl: expected balanced parentheses, got 1 '(' left open
    """
    if not isinstance(text, str):
        raise ValueError(f"{name}: expected PDDL text (a string), got {type(text).__name__}")
    tokens = _tokens(text, name)
    if tokens[0] != "(":
        raise ValueError(f"{name}: expected an expression starting with '(', got {_shown(tokens[0])}")
    stack: list = [[]]
    for k, tok in enumerate(tokens):
        if tok == "(":
            if len(stack) > MAX_PDDL_DEPTH:
                raise ValueError(f"{name}: expected parentheses nested at most {MAX_PDDL_DEPTH} deep (STRIPS "
                                 f"needs 5), got deeper nesting at token {k + 1}")
            stack.append([])
        elif tok == ")":
            if len(stack) == 1:
                raise ValueError(f"{name}: expected balanced parentheses, got an unmatched ')'")
            done = stack.pop()
            stack[-1].append(done)
            if len(stack) == 1 and k != len(tokens) - 1:
                raise ValueError(f"{name}: expected one expression, got more text after it "
                                 f"({' '.join(tokens[k + 1:k + 4])!r} ...)")
        else:
            stack[-1].append(tok)
    if len(stack) > 1:
        raise ValueError(f"{name}: expected balanced parentheses, got {len(stack) - 1} '(' left open")
    return stack[0][0]


def format_sexpr(expr) -> str:
    """PDDL text of a nested list.

    Examples
    --------
    >>> format_sexpr(["and", ["free", "?b"], ["not", ["pressed", "?b"]]])
    '(and (free ?b) (not (pressed ?b)))'
    """
    if isinstance(expr, str):
        return expr
    return "(" + " ".join(format_sexpr(e) for e in expr) + ")"


def _shown(value) -> str:
    """A name or an expression as it reads in a message, cut to a short line."""
    text = format_sexpr(value) if isinstance(value, (str, list)) else f"{type(value).__name__} {value!r}"
    text = text if isinstance(value, list) else repr(text) if isinstance(value, str) else text
    return text if len(text) <= 40 else text[:37] + "..."


def _check_name(value, what: str, name: str) -> str:
    if not isinstance(value, str) or not value or not value[0].isalpha() or not set(value) <= _NAME_CHARS:
        raise ValueError(f"{name}: expected {what} (a letter, then letters, digits, '-' or '_'), "
                         f"got {_shown(value)}")
    if what == "a predicate name" and value in _RESERVED:
        raise ValueError(f"{name}: expected {what}, got {value!r}, a word of PDDL's logic (rename the "
                         "predicate)")
    return value


def _typed_list(items, name: str, *, variables: bool) -> list:
    """``[(name, type)]`` of a PDDL typed list ``?a ?b - t ?c`` (untyped names are ``object``)."""
    out, pending, k = [], [], 0
    while k < len(items):
        tok = items[k]
        if tok == "-":
            if k + 1 >= len(items) or not pending:
                raise ValueError(f"{name}: expected '- TYPE' after names, got a '-' without both")
            kind = _check_name(items[k + 1], "a type name", name)
            out += [(p, kind) for p in pending]
            pending, k = [], k + 2
            continue
        if not isinstance(tok, str):
            raise ValueError(f"{name}: expected names, got {_shown(tok)}")
        if variables and not tok.startswith("?"):
            raise ValueError(f"{name}: expected parameters written ?name, got {_shown(tok)}")
        _check_name(tok[1:] if variables else tok, "a name", name)
        pending.append(tok)
        k += 1
    return out + [(p, "object") for p in pending]


def atoms_of(expr, name: str) -> list:
    """``[(negated, predicate, args)]`` of a conjunction of (possibly negated) atoms.

    Examples
    --------
    >>> atoms_of(["and", ["free", "?b"], ["not", ["pressed", "?b"]]], "effect")
    [(False, 'free', ('?b',)), (True, 'pressed', ('?b',))]
    """
    if isinstance(expr, str):
        raise ValueError(f"{name}: expected an atom or (and ...), got {_shown(expr)}")
    if not expr:
        return []
    head = expr[0]
    if head == "and":
        return [a for e in expr[1:] for a in atoms_of(e, name)]
    if head == "not":
        if len(expr) != 2 or isinstance(expr[1], str) or expr[1][:1] in (["and"], ["not"]):
            raise ValueError(f"{name}: expected (not ATOM), got {_shown(expr)}")
        return [(True, *atoms_of(expr[1], name)[0][1:])]
    if not isinstance(head, str) or any(not isinstance(a, str) for a in expr[1:]):
        raise ValueError(f"{name}: expected atoms (predicate arg ...) combined with 'and' and 'not' "
                         f"(STRIPS with negative preconditions), got {_shown(expr)}")
    return [(False, _check_name(head, "a predicate name", name), tuple(expr[1:]))]


@dataclass
class Action:
    """A PDDL action schema: name, typed parameters, precondition and effect.

    Attributes
    ----------
    name : str
    parameters : list of (str, str)
        ``("?b", "button")`` pairs, in order.
    precondition, effect : list
        Nested lists (see :func:`parse_sexpr`); ``[]`` for none.
    """

    name: str
    parameters: list
    precondition: list = field(default_factory=list)
    effect: list = field(default_factory=list)

    @property
    def text(self) -> str:
        """The schema as PDDL text."""
        params = " ".join(f"{p} - {t}" for p, t in self.parameters)
        out = f"(:action {self.name}\n  :parameters ({params})"
        if self.precondition:
            out += f"\n  :precondition {format_sexpr(self.precondition)}"
        return out + f"\n  :effect {format_sexpr(self.effect)})"

    def atoms(self) -> list:
        """``[(negated, predicate, args)]`` of the precondition and the effect."""
        return atoms_of(self.precondition, f"action {self.name} precondition") + \
            atoms_of(self.effect, f"action {self.name} effect")

    @property
    def negative(self) -> bool:
        """True when the precondition negates an atom (the domain then needs :negative-preconditions)."""
        return any(neg for neg, _, _ in atoms_of(self.precondition, "precondition"))


def _action(expr, name: str) -> Action:
    if not isinstance(expr, list) or len(expr) < 2 or expr[0] != ":action":
        raise ValueError(f"{name}: expected (:action NAME :parameters (...) :precondition ... :effect ...), "
                         f"got {format_sexpr(expr)[:60]!r}")
    act = _check_name(expr[1], "an action name", name)
    where = f"{name} {act}"
    keys = {}
    rest = expr[2:]
    if len(rest) % 2:
        raise ValueError(f"{where}: expected ':key value' pairs after the name, got an odd number of items")
    for key, value in zip(rest[::2], rest[1::2], strict=True):
        if key not in (":parameters", ":precondition", ":effect"):
            raise ValueError(f"{where}: expected keys :parameters, :precondition, :effect, got {_shown(key)}")
        keys[key] = value
    if ":effect" not in keys:
        raise ValueError(f"{where}: expected an :effect, got none")
    params = keys.get(":parameters", [])
    if isinstance(params, str):
        raise ValueError(f"{where}: expected :parameters (?x - type ...), got {_shown(params)}")
    parameters = _typed_list(params, f"{where} :parameters", variables=True)
    names = [p for p, _ in parameters]
    if len(set(names)) != len(names):
        raise ValueError(f"{where} :parameters: expected distinct names, got {names}")
    action = Action(act, parameters, keys.get(":precondition", []), keys[":effect"])
    for _, pred, args in action.atoms():
        unknown = [a for a in args if a.startswith("?") and a not in names]
        if unknown:
            raise ValueError(f"{where}: ({pred} {' '.join(args)}) uses {unknown[0]}, which is not a "
                             f"parameter (parameters {names})")
    return action


def parse_action(text: str, name: str = "action") -> Action:
    """Read one action schema ``(:action NAME :parameters (...) :precondition ... :effect ...)``.

    Examples
    --------
    >>> a = parse_action("(:action press :parameters (?b - button) :precondition (free ?b) "
    ...                  ":effect (and (pressed ?b) (not (free ?b))))")
    >>> a.name, a.parameters, a.negative
    ('press', [('?b', 'button')], False)
    >>> parse_action("(:action press :parameters (?b - button) :effect (pressed ?c))")
    Traceback (most recent call last):
    ...
    ValueError: action press: (pressed ?c) uses ?c, which is not a parameter (parameters ['?b'])
    """
    return _action(parse_sexpr(text, name), name)


@dataclass
class Domain:
    """A PDDL domain: its name, types, predicates (name -> argument types) and actions by name."""

    name: str
    types: list
    predicates: dict
    actions: dict
    text: str = ""


def _predicates(actions, name: str) -> dict:
    """Predicate -> argument types, gathered from the actions' parameters; one arity per predicate."""
    preds: dict = {}
    for act in actions:
        types = dict(act.parameters)
        for _, pred, args in act.atoms():
            kinds = [types.get(a, "object") for a in args]
            if pred in preds and len(preds[pred]) != len(kinds):
                raise ValueError(f"{name}: predicate {pred!r} is used with {len(preds[pred])} and with "
                                 f"{len(kinds)} argument(s) (action {act.name})")
            if pred in preds:  # one type per argument: a disagreement widens it to object
                kinds = [k if k == old else "object" for k, old in zip(kinds, preds[pred], strict=True)]
            preds[pred] = kinds
    return preds


def domain_text(actions, *, name: str = "skillbank", types=()) -> Domain:
    """A domain from action schemas: types and predicates gathered from them, as PDDL text too.

    Examples
    --------
    >>> a = parse_action("(:action press :parameters (?b - button) :effect (pressed ?b))")
    >>> d = domain_text([a])
    >>> d.predicates, d.types
    ({'pressed': ['button']}, ['button'])
    """
    actions = list(actions)
    kinds = sorted(({t for a in actions for _, t in a.parameters} | set(types)) - {"object"})
    preds = _predicates(actions, f"domain {name}")
    reqs = ":strips :typing" + (" :negative-preconditions" if any(a.negative for a in actions) else "")
    lines = [f"(define (domain {name})", f"  (:requirements {reqs})"]
    if kinds:
        lines.append(f"  (:types {' '.join(kinds)} - object)")
    if preds:
        body = " ".join("(" + " ".join([p] + [f"?x{k} - {t}" for k, t in enumerate(ts)]) + ")"
                        for p, ts in sorted(preds.items()))
        lines.append(f"  (:predicates {body})")
    for a in actions:
        lines.append("  " + a.text.replace("\n", "\n  "))
    text = "\n".join(lines) + ")\n"
    return Domain(name, kinds, preds, {a.name: a for a in actions}, text)


def parse_domain(text: str, name: str = "domain") -> Domain:
    """Read a domain: its name, types, predicates and actions (STRIPS, typing, negative preconditions).

    Examples
    --------
    >>> d = parse_domain("(define (domain d) (:requirements :strips :typing) (:types button) "
    ...                  "(:predicates (pressed ?b - button)) "
    ...                  "(:action press :parameters (?b - button) :effect (pressed ?b)))")
    >>> d.name, sorted(d.actions), d.predicates
    ('d', ['press'], {'pressed': ['button']})
    """
    expr = parse_sexpr(text, name)
    if not isinstance(expr, list) or expr[:1] != ["define"] or len(expr) < 2 or expr[1][:1] != ["domain"]:
        raise ValueError(f"{name}: expected (define (domain NAME) ...), got {format_sexpr(expr)[:60]!r}")
    dname = _check_name(expr[1][1] if len(expr[1]) == 2 else None, "a domain name", name)
    types, preds, actions = [], {}, {}
    for part in expr[2:]:
        if isinstance(part, str) or not part:
            raise ValueError(f"{name}: expected (:section ...), got {_shown(part)}")
        head = part[0]
        if head == ":types":
            types = sorted({t for pair in _typed_list(part[1:], f"{name} :types", variables=False)
                            for t in pair} - {"object"})
        elif head == ":predicates":
            for p in part[1:]:
                if isinstance(p, str) or not p:
                    raise ValueError(f"{name} :predicates: expected (name ?x - type ...), got {_shown(p)}")
                pname = _check_name(p[0], "a predicate name", f"{name} :predicates")
                preds[pname] = [t for _, t in _typed_list(p[1:], f"{name} :predicates", variables=True)]
        elif head == ":action":
            act = _action(part, name)
            actions[act.name] = act
        elif head not in (":requirements", ":constants"):
            raise ValueError(f"{name}: expected :requirements, :types, :predicates, :constants or :action "
                             f"sections, got {_shown(head)}")
    if not actions:
        raise ValueError(f"{name}: expected at least one (:action ...), got none")
    for act in actions.values():
        for _, pred, _args in act.atoms():
            if preds and pred not in preds:
                raise ValueError(f"{name}: action {act.name} uses predicate {pred!r}, which :predicates does "
                                 "not declare")
    if not preds:
        preds = _predicates(actions.values(), name)
    return Domain(dname, types, preds, actions, text)


def parse_atom(text, name: str) -> tuple:
    """``(predicate, args)`` of a ground atom such as ``"(pressed b1)"``.

    Examples
    --------
    >>> parse_atom("(on Block1 table)", "init[0]")
    ('on', ('block1', 'table'))
    >>> parse_atom("(on ?x table)", "goal[0]")
    Traceback (most recent call last):
    ...
    ValueError: goal[0]: expected a ground atom (predicate object ...), got '(on ?x table)'
    """
    if not isinstance(text, str):
        raise ValueError(f"{name}: expected an atom like '(pressed b1)', got {describe(text)}")
    expr = parse_sexpr(text, name)
    if (isinstance(expr, str) or not expr or any(not isinstance(e, str) for e in expr)
            or any(e.startswith("?") for e in expr)):
        raise ValueError(f"{name}: expected a ground atom (predicate object ...), got {_shown(text)}")
    return _check_name(expr[0], "a predicate name", name), tuple(expr[1:])


def problem_text(objects: dict, init, goal, *, domain: str, name: str = "scene") -> str:
    """A PDDL problem: ``objects`` name -> type, ``init`` and ``goal`` lists of ``(predicate, args)``.

    Examples
    --------
    >>> print(problem_text({"b1": "button"}, [("free", ("b1",))], [("pressed", ("b1",))], domain="d"))
    (define (problem scene) (:domain d)
      (:objects b1 - button)
      (:init (free b1))
      (:goal (and (pressed b1))))
    <BLANKLINE>
    """
    objs = " ".join(f"{o} - {t}" for o, t in objects.items())
    facts = " ".join(format_sexpr([p, *a]) for p, a in init)
    goals = " ".join(format_sexpr([p, *a]) for p, a in goal)
    return (f"(define (problem {name}) (:domain {domain})\n  (:objects {objs})\n  (:init {facts})\n"
            f"  (:goal (and {goals})))\n")
