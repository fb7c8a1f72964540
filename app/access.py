"""Who may use the API: one token, a ``Host`` allow-list and a cross-site check, in one pure ASGI
middleware in front of every route (``AccessMiddleware``); and no secret in the access log.

Decisions (compare Jupyter: a token on every route, a cross-site check, a ``Host`` allow-list):
- One token, ``FTIN_TOKEN`` (``FTIN_LIVE_TOKEN`` is its old name, still read). Without one the app
  generates one at each start (``secrets.token_urlsafe``): a server bound beyond loopback is never
  open, and ``uvicorn app.main:app`` on loopback still needs nothing, because a client on this machine
  needs no token. "On this machine": the client address uvicorn reports (``X-Forwarded-For`` included,
  which uvicorn trusts from 127.0.0.1 only) is loopback or one of this machine's own addresses (a
  socket can bind it). A reverse proxy on this machine must send ``X-Forwarded-For``, or every
  client looks local. Names that are no address (``testclient``: FastAPI's in-process client) only
  come from this process or a trusted proxy: local too.
- Every route but ``/health`` needs the token from another machine, in one of three ways:
  ``Authorization: Bearer <token>``; ``?token=<token>`` (a ``GET`` trades it for a cookie and is
  redirected to the same URL without it, like Jupyter's login URL; other methods, such as a phone's
  push URL, just use it); or that cookie (``HttpOnly``, ``SameSite=Lax``, an HMAC of the token, not
  the token). A token shown and wrong is refused even on this machine (a mistyped push URL says so).
  Comparisons are constant-time (``hmac.compare_digest``).
- ``Host`` must name this machine: loopback names and addresses, this machine's host names
  (``gethostname``, its FQDN, ``<name>.local``) and addresses, or ``FTIN_ALLOWED_HOSTS`` (``*``: any):
  400 otherwise. That stops DNS rebinding, which lets a web page read a server on 127.0.0.1.
- A state-changing request (``POST``/``PUT``/``DELETE``/``PATCH``) whose ``Origin`` is present must
  come from the server's own origin (the ``Host`` it was sent to, same port) or one of
  ``FTIN_CORS_ORIGINS``: 403 otherwise. Browsers send ``Origin`` with every cross-site ``POST``, which
  they send without asking for ``text/plain`` and multipart bodies; clients that are no browser (curl,
  a phone app's push) send none.
- The access log (uvicorn's, and gunicorn's) shows query strings with the value of every parameter
  whose name speaks of a secret (token, key, secret, password, auth) replaced by ``[redacted]``
  (``RedactSecrets``, installed by ``create_app``).
- The viser 3D scene is another server (``FTIN_VISER_HOST``, default 127.0.0.1): none of this guards
  it (docs/reliability.md#access says what it exposes).
"""

from __future__ import annotations

import functools
import hashlib
import hmac
import ipaddress
import logging
import os
import re
import secrets
import socket
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import parse_qsl, unquote_plus, urlencode, urlsplit

import click
import uvicorn
from starlette.datastructures import Headers
from starlette.requests import cookie_parser
from starlette.responses import JSONResponse, RedirectResponse, Response
from starlette.types import ASGIApp, Receive, Scope, Send

from app.settings import Settings

OPEN_PATHS = frozenset({"/health"})  # answered without a token (still Host-checked)
STATE_CHANGING = frozenset({"POST", "PUT", "DELETE", "PATCH"})
TOKEN_PARAM = "token"
COOKIE_NAME = "ftin_studio_token"
COOKIE_MAX_AGE_S = 30 * 24 * 3600
LOOPBACK_NAMES = frozenset({"localhost", "localhost.localdomain", "ip6-localhost", "ip6-loopback"})
LOCAL_CLIENT_NAMES = frozenset({"testclient", "localhost"})  # in-process clients: no address at all
SECRET_NAME = re.compile(r"token|secret|key|passw|auth", re.IGNORECASE)


@functools.lru_cache(maxsize=4096)
def _ip(text: str) -> ipaddress.IPv4Address | ipaddress.IPv6Address | None:
    try:
        return ipaddress.ip_address(text.strip("[]"))
    except ValueError:
        return None


_BOUND: dict[str, tuple[bool, float]] = {}  # address -> (this machine's, until when): addresses change
BOUND_TTL_S = 30.0


def is_this_machine(address: str) -> bool:
    """Whether ``address`` (an IP) is loopback or one of this machine's: a socket can bind it."""
    ip = _ip(address)
    if ip is None or ip.is_unspecified or ip.is_multicast:
        return False
    if ip.is_loopback:
        return True
    known = _BOUND.get(address)
    if known is not None and known[1] > time.monotonic():
        return known[0]
    family = socket.AF_INET6 if ip.version == 6 else socket.AF_INET
    try:
        with socket.socket(family, socket.SOCK_DGRAM) as probe:
            probe.bind((str(ip), 0))
        mine = True
    except OSError:
        mine = False
    if len(_BOUND) > 4096:
        _BOUND.clear()
    _BOUND[address] = (mine, time.monotonic() + BOUND_TTL_S)
    return mine


def is_local(client_host: str | None) -> bool:
    """Whether a client (the address uvicorn reports) is on this machine (module docstring)."""
    if not client_host:
        return True
    if _ip(client_host) is None:
        return client_host in LOCAL_CLIENT_NAMES
    return is_this_machine(client_host)


def machine_names() -> frozenset[str]:
    """This machine's own host names, lower case."""
    names = set(LOOPBACK_NAMES)
    try:
        hostname = socket.gethostname().lower()
        names |= {hostname, f"{hostname}.local", socket.getfqdn().lower()}
    except OSError:
        pass
    return frozenset(n.rstrip(".") for n in names if n)


@dataclass
class AccessPolicy:
    """What ``AccessMiddleware`` checks, from the settings (one per app)."""

    token: str
    token_generated: bool  # no FTIN_TOKEN: this one is new at this start
    host_names: frozenset[str]  # lower case, without trailing dots
    any_host: bool
    cors_origins: frozenset[str]
    announced: bool = field(default=False, compare=False)  # the URL to open was printed

    @classmethod
    def from_settings(cls, settings: Settings) -> AccessPolicy:
        extra = {h.strip().lower().rstrip(".") for h in settings.allowed_hosts if h.strip()}
        return cls(
            token=settings.token or secrets.token_urlsafe(24),
            token_generated=settings.token is None,
            host_names=machine_names() | (extra - {"*"}),
            any_host="*" in extra,
            cors_origins=frozenset(o.rstrip("/") for o in settings.cors_origins),
        )

    def token_ok(self, candidate: str) -> bool:
        return hmac.compare_digest(candidate.encode(), self.token.encode())

    @property
    def cookie_value(self) -> str:
        """What the cookie holds: an HMAC of the token (another server on this host sees the cookie)."""
        return hmac.new(self.token.encode(), b"ftin-studio cookie", hashlib.sha256).hexdigest()

    def cookie_ok(self, candidate: str) -> bool:
        return hmac.compare_digest(candidate.encode(), self.cookie_value.encode())

    def host_allowed(self, host_header: str) -> bool:
        """Whether a ``Host`` header (``name[:port]``) names this server."""
        if self.any_host:
            return True
        name = _host_name(host_header)
        if name is None:
            return False
        if name in self.host_names or name.endswith(".localhost"):  # *.localhost is loopback (RFC 6761)
            return True
        return _ip(name) is not None and is_this_machine(name)

    def origin_allowed(self, origin: str, host_header: str | None, scheme: str) -> bool:
        """Whether a state-changing request's ``Origin`` is the server's own (the scheme, name and port
        it was sent to) or one of the CORS origins."""
        origin = origin.strip().rstrip("/")
        if origin in self.cors_origins:
            return True
        defaults = {"http": 80, "https": 443}
        try:
            parts = urlsplit(origin)
            target = urlsplit(f"{scheme}://{host_header}") if host_header else None
            mine = None if target is None else (scheme, target.hostname, target.port or defaults.get(scheme))
            theirs = (parts.scheme, parts.hostname, parts.port or defaults.get(parts.scheme))
        except ValueError:
            return False
        return mine is not None and parts.hostname is not None and not parts.path and theirs == mine


@functools.lru_cache(maxsize=1024)
def _host_name(host_header: str) -> str | None:
    if re.search(r"[@/?#\\\s]", host_header):  # a name and port only: no user, path or space
        return None
    try:
        parts = urlsplit(f"//{host_header}")
        parts.port  # noqa: B018 - raises ValueError on a port that is not one
    except ValueError:
        return None
    return (parts.hostname or "").rstrip(".") or None


def _refuse(status: int, detail: str, headers: dict[str, str] | None = None) -> Response:
    return JSONResponse({"detail": detail}, status_code=status, headers=headers)


UNAUTHORIZED = {"WWW-Authenticate": "Bearer"}
NEEDS_TOKEN = (
    "this server needs its token from other machines: open the URL it printed at start "
    "(http://<address>:<port>/?token=<token>), add ?token=<token> to a phone app's push URL, or send "
    "'Authorization: Bearer <token>' (the token: FTIN_TOKEN, or the one printed at start; the upload "
    "page on the server's own machine shows the push URL with it)"
)


class AccessMiddleware:
    """Pure ASGI middleware: 400 unknown ``Host``, 403 cross-site state change, 401 no token."""

    def __init__(self, app: ASGIApp, policy: AccessPolicy) -> None:
        self.app = app
        self.policy = policy

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        refusal = self._check(scope)
        if refusal is None:
            await self.app(scope, receive, send)
        elif scope["type"] == "websocket":
            await send({"type": "websocket.close", "code": 1008})
        else:
            await refusal(scope, receive, send)

    def _check(self, scope: Scope) -> Response | None:
        policy, headers = self.policy, Headers(scope=scope)
        host = headers.get("host")
        if host is not None and not policy.host_allowed(host):
            return _refuse(
                400,
                f"this server does not answer to the host name {host[:100]!r}: open it by this machine's "
                "name or address, or add the name to FTIN_ALLOWED_HOSTS",
            )
        method = scope.get("method", "GET")
        origin = headers.get("origin")
        scheme = str(scope.get("scheme", "http")).replace("ws", "http")
        if (
            method in STATE_CHANGING
            and origin is not None
            and not policy.origin_allowed(origin, host, scheme)
        ):
            return _refuse(
                403,
                f"cross-site request refused: a page from {origin[:100]!r} may not change this server "
                "(FTIN_CORS_ORIGINS lists the origins allowed to)",
            )
        preflight = method == "OPTIONS" and "access-control-request-method" in headers
        if scope["path"] in OPEN_PATHS or preflight:  # a CORS preflight carries no credentials
            return None
        query = parse_qsl(scope.get("query_string", b"").decode("latin-1"), keep_blank_values=True)
        shown = next((value for name, value in query if name == TOKEN_PARAM), None)
        auth = headers.get("authorization", "")
        if shown is None and auth[:7].lower() == "bearer ":
            shown = auth[7:].strip()
        if shown is not None:
            if not policy.token_ok(shown):
                return _refuse(401, "wrong token: " + NEEDS_TOKEN, UNAUTHORIZED)
            if method in ("GET", "HEAD") and any(name == TOKEN_PARAM for name, _ in query):
                return self._login(scope, query)
            return None
        cookie = cookie_parser(headers.get("cookie", "")).get(COOKIE_NAME)
        if cookie is not None and policy.cookie_ok(cookie):
            return None
        client, server = scope.get("client"), scope.get("server")
        if server and not policy.announced and _ip(str(server[0])) is not None:  # a socket's address
            announce(policy, str(server[0]), int(server[1] or 80))  # a launcher whose bind we did not know
        if is_local(client[0] if client else None):
            return None
        if cookie is not None:
            stale = "this browser's token is out of date (a restart makes a new one): "
            return _refuse(401, stale + NEEDS_TOKEN, UNAUTHORIZED)
        return _refuse(401, NEEDS_TOKEN, UNAUTHORIZED)

    def _login(self, scope: Scope, query: list[tuple[str, str]]) -> Response:
        """The same URL without the token, with the cookie that stands for it from now on."""
        rest = urlencode([(n, v) for n, v in query if n != TOKEN_PARAM])
        response = RedirectResponse(scope["path"] + (f"?{rest}" if rest else ""), status_code=302)
        response.set_cookie(
            COOKIE_NAME,
            self.policy.cookie_value,
            max_age=COOKIE_MAX_AGE_S,
            httponly=True,
            samesite="lax",
            secure=scope.get("scheme") == "https",
        )
        return response


# --- the URL to open, printed when the app is reachable from other machines ------------------------

# Documentation-only ranges (RFC 5737, RFC 3849): never an address a phone can reach.
NOT_REACHABLE = tuple(
    ipaddress.ip_network(n) for n in ("192.0.2.0/24", "198.51.100.0/24", "203.0.113.0/24", "2001:db8::/32")
)
ROUTE_PROBES = ("10.255.255.255", "192.168.255.255", "172.31.255.255", "8.8.8.8")  # UDP: nothing is sent


def _usable(address: str) -> bool:
    """An address a phone on the LAN could reach: not loopback, link-local, unspecified or documentation."""
    ip = _ip(address)
    if ip is None:
        return False
    unusable = ip.is_loopback or ip.is_link_local or ip.is_unspecified
    return not (unusable or any(ip in n for n in NOT_REACHABLE))


def lan_addresses() -> list[str]:
    """This machine's IPv4 addresses on its networks, the default route's first: a UDP "connect" only
    picks the interface that would route to a probe address (no packet leaves), then the host name's
    addresses (``getaddrinfo``) for a machine without a route."""
    found: list[str] = []
    for probe_address in ROUTE_PROBES:
        try:
            with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
                probe.connect((probe_address, 9))
                found.append(probe.getsockname()[0])
        except OSError:
            continue
    try:
        infos = socket.getaddrinfo(socket.gethostname(), None, socket.AF_INET, socket.SOCK_STREAM)
        found += [str(info[4][0]) for info in infos]
    except OSError:
        pass
    return list(dict.fromkeys(a for a in found if _usable(a)))


def is_loopback_bind(host: str) -> bool:
    ip = _ip(host)
    return host.lower() in LOOPBACK_NAMES or (ip is not None and ip.is_loopback)


def uvicorn_cli_bind() -> tuple[str, int] | None:
    """The host and port ``uvicorn app.main:app ...`` was told to bind (uvicorn's own parser on this
    process's arguments and ``UVICORN_*`` variables); None when another program runs the app."""
    program = sys.argv[0] if sys.argv else ""
    if Path(program).stem != "uvicorn" and not program.endswith(os.path.join("uvicorn", "__main__.py")):
        return None
    try:
        params = uvicorn.main.make_context("uvicorn", sys.argv[1:], resilient_parsing=True).params
    except (click.ClickException, ValueError, TypeError):
        return None
    if params.get("uds") or params.get("fd") is not None:
        return None
    return str(params.get("host") or "127.0.0.1"), int(params.get("port") or 8000)


def announce(policy: AccessPolicy, host: str, port: int) -> None:
    """Print (to stderr, not to a log) the URL another machine opens, once, when ``host`` is beyond
    loopback: with the token when it was generated, else with ``<FTIN_TOKEN>`` in its place."""
    if policy.announced or is_loopback_bind(host):
        return
    policy.announced = True
    ip = _ip(host)
    everywhere = ip is not None and ip.is_unspecified  # 0.0.0.0 or ::
    addresses = (lan_addresses() or [socket.gethostname()]) if everywhere else [host]
    shown = policy.token if policy.token_generated else "<FTIN_TOKEN>"
    urls = [f"http://{f'[{a}]' if ':' in a else a}:{port}/?{TOKEN_PARAM}={shown}" for a in addresses]
    lines = [
        f"FTIN Studio answers other machines on {host}:{port}; they need its token. Open this on your phone "
        "or another computer (the page then keeps the token in a cookie):",
        *(f"    {url}" for url in urls),
        "The token is new at every start: set FTIN_TOKEN=<a secret of 8+ characters> for one that stays."
        if policy.token_generated
        else "(<FTIN_TOKEN>: the token this server was started with.)",
    ]
    print("\n".join(lines), file=sys.stderr, flush=True)


def deprecation_notes() -> list[str]:
    if "FTIN_LIVE_TOKEN" in os.environ and "FTIN_TOKEN" not in os.environ:
        return ["FTIN_LIVE_TOKEN is the old name of FTIN_TOKEN, the one token of every route: rename it"]
    return []


# --- the access log ------------------------------------------------------------------------------


def redact_query(target: str) -> str:
    """``target`` (a path and query) with every secret-named parameter's value ``[redacted]``."""
    path, mark, query = target.partition("?")
    if not mark:
        return target
    parts = re.split(r"([&;])", query)
    for i, part in enumerate(parts):
        name, equals, _ = part.partition("=")
        if equals and SECRET_NAME.search(unquote_plus(name)):
            parts[i] = f"{name}=[redacted]"
    return f"{path}?{''.join(parts)}"


class RedactSecrets(logging.Filter):
    """Redacts the query strings in an access log record's arguments (uvicorn passes the request
    target as one of them)."""

    def filter(self, record: logging.LogRecord) -> bool:
        if isinstance(record.args, tuple):
            record.args = tuple(redact_query(a) if isinstance(a, str) else a for a in record.args)
        if isinstance(record.msg, str) and "?" in record.msg:
            record.msg = redact_query(record.msg)
        return True


ACCESS_LOGGERS = ("uvicorn.access", "gunicorn.access")


def install_log_redaction() -> None:
    """Put ``RedactSecrets`` on the access loggers once (a logger's filters survive uvicorn's
    ``dictConfig``, which runs before it imports the app)."""
    for name in ACCESS_LOGGERS:
        logger = logging.getLogger(name)
        if not any(isinstance(f, RedactSecrets) for f in logger.filters):
            logger.addFilter(RedactSecrets())
