"""Connection strings and the passwords in them: every written form recognised, the password masked.

A library location can carry a password in four forms: a URL's user part
(``postgresql://ann:s3cret@db/skills``), a query parameter (``?password=``,
``?sslpassword=``), a libpq keyword string (``host=db password=s3cret``) and a URL
written without its scheme or its ``//`` (``ann:s3cret@db/skills``,
``postgresql:ann:s3cret@db/skills``). :func:`mask_url` hides the password in every
one of them, :func:`secrets` lists it (as written and percent-decoded) so that
:func:`scrub` can remove it from a driver's message, and :func:`check_url` refuses a
URL whose password cannot be told from the rest (a raw ``@``, ``/``, ``?`` or
``#``), saying to percent-encode it.
"""

from __future__ import annotations

import re
from urllib.parse import unquote

from ..core._text import CONTROL

__all__ = ["mask_url", "mask_text", "secrets", "scrub", "check_url", "keyword_string", "credential_shape",
           "SCHEME_URL", "CONTROL"]

#: ``scheme://rest`` (the rest may hold anything, newlines included, so that it is masked too).
SCHEME_URL = re.compile(r"^([A-Za-z][A-Za-z0-9+.-]*)://(.*)\Z", re.S)
# from the start of a run of scheme characters only: linear time on a long run without '://'
_SCHEME_ANYWHERE = re.compile(r"(?<![A-Za-z0-9+.-])[A-Za-z][A-Za-z0-9+.-]*://")
# A query parameter holding a secret; its value runs to the next '&key=' (a raw '&' stays masked).
_QUERY_SECRET = re.compile(r"([?&](?:ssl)?password=)(.*?)(?=&[A-Za-z_][A-Za-z0-9_]*=|\Z)", re.I | re.S)
_QUERY_FIRST = re.compile(r"[?&](?:ssl)?password=([^&]*)", re.I)  # libpq's reading: to the next '&'
# A keyword string's secret: a quoted value (an unterminated quote runs to the end) or a bare word.
_KEYWORD_SECRET = re.compile(r"(\b(?:ssl)?password\s*=\s*)('(?:[^'\\]|\\.)*'?|\S*)", re.I | re.S)
_KEYWORD = re.compile(r"^\s*([A-Za-z_]+)\s*=")
# user:...@ before the last '@', the user holding no '/' (so './a:b@c' stays a file name)
_CREDENTIALS = re.compile(r"^([^/:@]*):(.*)@", re.S)
_BAD_PERCENT = re.compile(r"%(?![0-9A-Fa-f]{2})")

#: libpq's connection keywords (libpq 16); a location starting with one of them and '=' is a keyword string.
LIBPQ_KEYWORDS = frozenset("""host hostaddr port dbname user password passfile require_auth channel_binding
connect_timeout client_encoding options application_name fallback_application_name keepalives
keepalives_idle keepalives_interval keepalives_count tcp_user_timeout replication gssencmode sslmode
requiressl sslcompression sslcert sslkey sslpassword sslcertmode sslrootcert sslcrl sslcrldir sslsni
requirepeer ssl_min_protocol_version ssl_max_protocol_version krbsrvname gsslib gssdelegation service
target_session_attrs load_balance_hosts sslnegotiation""".split())

# No example password: one the user's might equal would show theirs, percent-encoded.
_ENCODE = ("percent-encode the password and these characters anywhere after the host: '?' as %3F, "
           "'#' as %23, '@' as %40, '/' as %2F, '%' as %25, '&' as %26 "
           "(urllib.parse.quote(password, safe=''))")


def keyword_string(text: str) -> bool:
    """Whether ``text`` is a libpq keyword string (``host=db dbname=skills ...``)."""
    m = _KEYWORD.match(text)
    return m is not None and m.group(1).lower() in LIBPQ_KEYWORDS


def _bare_credentials(text: str):
    """``(prefix, password, tail)`` of ``user:password@host...`` written without ``scheme://``, else None.

    After ``postgresql:`` or ``postgres:`` the user is shown; otherwise everything from the first ':' to
    the last '@' is taken for the password (``ann:pw:x@db`` may be user ``ann`` or ``ann:pw``).
    """
    if not credential_shape(text):
        return None
    head, _, rest = text.partition(":")
    if head.lower() in ("postgresql", "postgres") and credential_shape(rest):
        user, _, rest = rest.partition(":")
        head = f"{head}:{user}"
    password, _, host = rest.rpartition("@")
    return f"{head}:", password, f"@{host}"


def credential_shape(text: str) -> bool:
    """Whether ``text`` reads as ``user:password@host...`` (a URL without its scheme), not as a path.

    A drive letter (``C:\\``) is a path; ``./`` in front makes any name a path.
    """
    return _CREDENTIALS.match(text) is not None and re.match(r"^[A-Za-z]:[\\/]", text) is None


def _split_user(rest: str):
    """``(user, password, tail)`` of a URL's rest after ``://``: the password runs from the first ':'
    before the last '@' to that '@' (all of what any parser could take for it); None without one.

    A URL in which that differs from libpq's reading (a raw '@', '/', '?' or '#') is refused by
    :func:`check_url`, so only its refusal shows this wider mask.
    """
    at = rest.rfind("@")
    colon = rest.find(":", 0, max(at, 0))
    if at < 0 or colon < 0:
        return None
    return rest[:colon], rest[colon + 1:at], rest[at:]


def _mask_rest(rest: str) -> str:
    """The part of a URL after ``://`` with its passwords masked."""
    split = _split_user(rest)
    if split is not None:
        user, password, tail = split
        rest = f"{user}:{'***' if password else ''}{tail}"
    return _QUERY_SECRET.sub(lambda m: m.group(1) + ("***" if m.group(2) else ""), rest)


def mask_url(url) -> str:
    """``url`` (any form of library location) with every password in it shown as ``***``.

    Examples
    --------
    >>> mask_url("postgresql://ann:s3cret@db.lab:5432/skills?sslmode=require")
    'postgresql://ann:***@db.lab:5432/skills?sslmode=require'
    >>> mask_url("postgres:///skills?host=/run/pg&password=s3cret")
    'postgres:///skills?host=/run/pg&password=***'
    >>> mask_url("postgresql://ann:s3c?ret@db/skills")  # a raw '?': still all of it
    'postgresql://ann:***@db/skills'
    >>> mask_url("host=db password='s3 cret' dbname=skills")
    'host=db password=*** dbname=skills'
    >>> mask_url("postgresql:ann:s3cret@db/skills")
    'postgresql:ann:***@db/skills'
    >>> mask_url("postgresql://postgres:@/skills?host=/tmp/pg")  # an empty password hides nothing
    'postgresql://postgres:@/skills?host=/tmp/pg'
    >>> mask_url("lib.db")
    'lib.db'
    """
    text = str(url)
    m = _SCHEME_ANYWHERE.search(text)
    if m is not None:  # a URL, or one with something before its scheme (a space, a newline)
        return text[:m.end()] + _mask_rest(text[m.end():])
    if keyword_string(text):
        return _KEYWORD_SECRET.sub(lambda k: k.group(1) + "***", text)
    bare = _bare_credentials(text)
    if bare is not None:
        prefix, password, tail = bare
        return f"{prefix}{'***' if password else ''}{tail}"
    return text


def mask_text(text) -> str:
    """Free text (a message quoting arguments) with the password of every location written in it masked.

    Each ``password=`` value and each space-separated word that is a location
    (a URL, ``user:password@host``) is masked as :func:`mask_url` masks it.

    Examples
    --------
    >>> mask_text("unrecognized arguments: postgresql://ann:s3cret@db/x host=db password=s3cret ann:pw@db")
    'unrecognized arguments: postgresql://ann:***@db/x host=db password=*** ann:***@db'
    """
    text = _KEYWORD_SECRET.sub(lambda k: k.group(1) + "***", str(text))
    return " ".join(mask_url(word) for word in text.split(" "))


def _unquote_keyword(value: str) -> str:
    if value.startswith("'"):
        value = value[1:-1] if len(value) > 1 and value.endswith("'") else value[1:]
        return re.sub(r"\\(.)", r"\1", value)
    return value


def secrets(location) -> list[str]:
    """Every password ``location`` holds, as written and percent-decoded, longest first (none: ``[]``).

    Both readings of an ambiguous URL are included: all of what could be the
    password (to the last '@') and what libpq takes (to the first).

    Examples
    --------
    >>> secrets("postgresql://ann:a%40b@db/skills?sslpassword=k3y")
    ['a%40b', 'k3y', 'a@b']
    """
    text = str(location)
    found = []
    m = _SCHEME_ANYWHERE.search(text)
    if m is not None:
        rest = text[m.end():]
        split = _split_user(rest)
        if split is not None:
            found.append(split[1])
            user = rest.split("@", 1)[0]
            found.append(user.partition(":")[2])  # libpq's reading: up to the first '@'
        found += [value for _, value in _QUERY_SECRET.findall(rest)] + _QUERY_FIRST.findall(rest)
    elif keyword_string(text):
        found += [_unquote_keyword(value) for _, value in _KEYWORD_SECRET.findall(text)]
    elif _bare_credentials(text) is not None:
        found.append(_bare_credentials(text)[1])
    found += [unquote(p) for p in found]
    return sorted({p for p in found if p}, key=lambda p: (-len(p), found.index(p)))


def scrub(text: str, url: str) -> str:
    """``text`` (a driver's message) on one line, with the password of ``url``, as written or decoded, masked.

    libpq quotes the bad part of a malformed URL, which may be the password.

    Examples
    --------
    >>> scrub('invalid percent-encoded token: "se%zz"', "postgresql://ann:se%zz@db/skills")
    'invalid percent-encoded token: "***"'
    """
    text = str(text)
    for secret in secrets(url):
        text = text.replace(secret, "***")
    return " ".join(text.split())


def check_url(url: str) -> str:
    """``url`` with its scheme in lower case, or a one-line ValueError (password masked) when libpq would
    read it otherwise than it reads: a raw '@', '/', '?' or '#' in the password (or '@' or '#' after the
    host), a '%' not followed by two hex digits in the user part, or a query parameter without '='.

    Examples
    --------
    >>> check_url("POSTGRESQL://ann:s3c%3Fret@db/skills")
    'postgresql://ann:s3c%3Fret@db/skills'
    >>> check_url("postgresql://ann:s3c?ret@db/skills")
    Traceback (most recent call last):
    ...
    ValueError: library 'postgresql://ann:***@db/skills': cannot tell the password from the rest of the URL \
(a raw '@', '/', '?' or '#'); percent-encode the password and these characters anywhere after the host: \
'?' as %3F, '#' as %23, '@' as %40, '/' as %2F, '%' as %25, '&' as %26 (urllib.parse.quote(password, safe=''))
    """
    text = str(url)
    m = SCHEME_URL.match(text)
    shown = mask_url(text)
    if m is None:
        raise ValueError(f"library {shown!r}: expected a URL postgresql://[user[:password]@][host][:port]"
                         "[/dbname][?param=value]")
    if CONTROL.search(text):
        raise ValueError(f"library {shown!r}: a URL holds no control characters (a newline, NUL or escape); "
                         "remove them")
    scheme, rest = m.groups()
    ats = [i for i, c in enumerate(rest) if c == "@"]
    host_end = min((i for i in (rest.find("/"), rest.find("?")) if i >= 0), default=len(rest))
    if "#" in rest or len(ats) > 1 or (ats and ats[0] > host_end):
        raise ValueError(f"library {shown!r}: cannot tell the password from the rest of the URL (a raw '@', "
                         f"'/', '?' or '#'); {_ENCODE}")
    if ats and _BAD_PERCENT.search(rest[:ats[0]]):
        raise ValueError(f"library {shown!r}: a '%' in the user part is not followed by two hex digits; "
                         f"{_ENCODE}")
    query = rest.partition("?")[2]
    if any(piece and "=" not in piece for piece in query.split("&")):
        raise ValueError(f"library {shown!r}: a query parameter without '=' (expected ?param=value&...); "
                         f"{_ENCODE}")
    return f"{scheme.lower()}://{rest}"
