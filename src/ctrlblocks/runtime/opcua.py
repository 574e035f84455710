"""OPC UA client adapter (asyncua) and the security helpers shared with the plant server.

Addresses are node ids as OPC UA writes them (``ns=2;s=pv``, ``ns=3;i=1001``).
The adapter reads all addresses of a cycle in one Read service call and
writes in one Write call, chunked to the server's operation limits
(``MaxNodesPerRead``/``MaxNodesPerWrite`` of its ServerCapabilities, read
once at connect; 0 or absent = no limit).

Timeouts: the asyncua client's own request timeout and health probe are set
to the connection's ``connect_timeout`` (a session set-up takes several
round trips); the per-request ``timeout`` is enforced by the
:class:`~ctrlblocks.runtime.io.Connection` on the wire, so a slow answer is a
counted timeout, not a dropped connection.

Float vs double: the data type of each node is read once, at its first use;
values are written as a Variant of that type (``Float`` nodes get a FLOAT32,
``Double`` nodes a FLOAT64, integer nodes a rounded integer, ``Boolean``
nodes a value of 0 or 1 -- any other value is refused for that item, as a
status bit such as an alarm flag is never rounded), because a server may
refuse a write whose Variant type differs from the node's
(``BadTypeMismatch``).  Reads of any numeric type (and of ``Boolean``: 1.0 /
0.0) come back as Python floats.

Quality: a value whose StatusCode is not Good, whose value is not a finite
number, or (with ``stale_after > 0``) whose SourceTimestamp is older than
``stale_after`` seconds is a bad reading (``y_ok`` false for the loop).

Security (``security = "Basic256Sha256_SignAndEncrypt"``): the client signs
and encrypts with its certificate and private key, checks that the server
presents exactly the configured ``server_certificate`` (the client's trust
list), and authenticates with ``user``/``password``.  The server side
(:func:`trust_list_validator`) accepts only client certificates in its trust
list -- never any certificate by default.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import hashlib
import logging
import math
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path
from typing import Any

from .config import ConnectionConfig
from .io import Adapter, IOFault, Reading, bad, checked, describe

__all__ = [
    "OpcUaAdapter",
    "fingerprint",
    "make_certificate",
    "trust_list_validator",
]

log = logging.getLogger(__name__)


def _asyncua() -> Any:
    try:
        import asyncua
    except ImportError as exc:  # pragma: no cover - depends on the install
        raise ImportError(
            "the OPC UA adapter needs asyncua: pip install 'ctrlblocks[runtime]'"
        ) from exc
    return asyncua


@contextlib.contextmanager
def _faults(what: str) -> Iterator[None]:
    """A lost connection or a service failure during ``what`` as :class:`IOFault`."""
    from asyncua import ua

    try:
        yield
    except (ConnectionError, OSError, TimeoutError, ua.UaError) as exc:
        raise IOFault(f"OPC UA {what}: {describe(exc)}") from exc


def _answered(results: Sequence[Any], nodes: Sequence[Any], what: str) -> None:
    """Raise :class:`IOFault` unless the server gave one result per node (OPC UA Part 4,
    Read and Write: ``Results`` has the length of the request's list); results of
    another length are never matched to the nodes."""
    if len(results) != len(nodes):
        raise IOFault(f"OPC UA {what}: the server answered {len(results)} results to "
                      f"{len(nodes)} nodes")  # fmt: skip


class OpcUaAdapter(Adapter):
    """OPC UA client (see the module docstring)."""

    def __init__(self, config: ConnectionConfig) -> None:
        self.config = config
        self._client: Any = None
        self._types: dict[str, Any] = {}  # address -> VariantType of the node
        self._nodeids: dict[str, Any] = {}  # address -> parsed NodeId
        self.max_nodes = {"read": 0, "write": 0}  # the server's operation limits (0: none)
        if config.password is not None and config.security == "none":
            log.warning(
                "connection %s: a password without security may cross the network unencrypted",
                config.name,
            )

    async def connect(self) -> None:
        asyncua = _asyncua()
        from asyncua import ua
        from asyncua.crypto.security_policies import SecurityPolicyBasic256Sha256

        c = self.config
        mismatch: list[str] = []  # set by the certificate check: the real reason of a failure
        expected = ""
        client = asyncua.Client(
            c.url, timeout=c.connect_timeout, watchdog_intervall=max(c.connect_timeout, 1.0)
        )
        client.application_uri = c.application_uri
        if c.security != "none":
            await client.set_security(
                SecurityPolicyBasic256Sha256,
                certificate=c.certificate,
                private_key=c.private_key,
                server_certificate=c.server_certificate,
                mode=ua.MessageSecurityMode.SignAndEncrypt,
            )
            expected = fingerprint(_load_der(Path(c.server_certificate)))  # type: ignore[arg-type]

            async def check_server(cert: Any, app: Any) -> None:
                from asyncua.common.utils import ServiceError
                from cryptography.hazmat.primitives.serialization import Encoding

                got = fingerprint(cert.public_bytes(Encoding.DER))
                if got != expected:
                    mismatch.append(
                        f"the server's certificate (SHA-256 {got[:16]}...) is not the pinned "
                        f"server_certificate {c.server_certificate} ({expected[:16]}...)"
                    )
                    raise ServiceError(ua.StatusCodes.BadCertificateUntrusted)

            client.certificate_validator = check_server
        if c.user is not None:
            client.set_user(c.user)
            client.set_password(c.password or "")
        try:
            await client.connect()
        except BaseException as exc:  # also a cancelled (timed-out) connect: no half-open client
            with contextlib.suppress(Exception):
                await client.disconnect()
            if not mismatch and c.security != "none" and isinstance(exc, Exception):
                mismatch += await _pinned_mismatch(c, expected)
            if mismatch:
                raise IOFault(f"OPC UA connect {c.url}: {mismatch[0]}") from exc
            if not isinstance(exc, Exception):
                raise
            raise IOFault(f"OPC UA connect {c.url}: {describe(exc)}") from exc
        self._client = client
        self._types = {}
        self.max_nodes = await _operation_limits(client)

    async def close(self) -> None:
        client, self._client = self._client, None
        if client is not None:
            try:
                await client.disconnect()
            except Exception:  # the server may be gone
                log.debug("OPC UA disconnect failed", exc_info=True)

    def _live(self) -> Any:
        if self._client is None:
            raise IOFault("OPC UA connection closed")
        return self._client

    def _nodeid(self, address: str) -> Any:
        """The parsed NodeId of ``address`` (parsed once)."""
        nid = self._nodeids.get(address)
        if nid is None:
            from asyncua import ua

            nid = self._nodeids[address] = ua.NodeId.from_string(address)
        return nid

    async def _variant_types(self, addresses: Iterable[str]) -> None:
        from asyncua import ua

        client = self._live()
        new = [a for a in addresses if a not in self._types]
        if not new:
            return
        dvs = []
        for chunk in _chunks([self._nodeid(a) for a in new], self.max_nodes["read"]):
            self.count("read")
            got = await client.uaclient.read_attributes(chunk, ua.AttributeIds.DataType)
            _answered(got, chunk, "read of the data types")
            dvs += got
        for a, dv in zip(new, dvs, strict=True):
            vt = None
            if dv.StatusCode is None or dv.StatusCode.is_good():
                nid = dv.Value.Value
                if isinstance(nid, ua.NodeId) and nid.NamespaceIndex == 0:
                    vt = _DATA_TYPES.get(nid.Identifier)
            self._types[a] = vt

    async def read(self, addresses: Sequence[str]) -> list[Reading]:
        from asyncua import ua

        client = self._live()
        try:
            nodeids = [self._nodeid(a) for a in addresses]
        except Exception as exc:  # a malformed node id
            return [bad(f"bad node id: {exc}")] * len(addresses)
        dvs = []
        with _faults("read"):
            for chunk in _chunks(nodeids, self.max_nodes["read"]):
                self.count("read")
                got = await client.uaclient.read_attributes(chunk, ua.AttributeIds.Value)
                _answered(got, chunk, "read")
                dvs += got
        now = _dt.datetime.now(_dt.timezone.utc)
        out = []
        for dv in dvs:
            if dv.StatusCode is not None and not dv.StatusCode.is_good():
                out.append(bad(f"status {dv.StatusCode.name}"))
                continue
            value = dv.Value.Value if dv.Value is not None else None
            r = checked(value)
            stale = self.config.stale_after
            if r.ok and stale > 0 and dv.SourceTimestamp is not None:
                ts = dv.SourceTimestamp
                if ts.tzinfo is None:
                    ts = ts.replace(tzinfo=_dt.timezone.utc)
                if (now - ts).total_seconds() > stale:
                    r = Reading(r.value, False, "stale")
            out.append(r)
        return out

    async def write(self, items: Sequence[tuple[str, float]]) -> list[str | None]:
        from asyncua import ua

        client = self._live()
        with _faults("read data type"):
            await self._variant_types(a for a, _ in items)
        nodeids, dvs, res_pre = [], [], []
        for a, v in items:
            vt = self._types.get(a)
            if vt is None:
                res_pre.append(f"{a}: not a numeric variable")
                continue
            x: Any = float(v)
            if vt == ua.VariantType.Boolean:
                if x not in (0.0, 1.0):
                    res_pre.append(f"{a}: {x!r} does not fit a Boolean node (0 or 1)")
                    continue
                x = x == 1.0
            elif vt not in (ua.VariantType.Float, ua.VariantType.Double):
                if not math.isfinite(x):
                    res_pre.append(f"{a}: {x!r} does not fit an integer node")
                    continue
                x = round(x)
            nodeids.append(self._nodeid(a))
            dvs.append(ua.DataValue(ua.Variant(x, vt)))
            res_pre.append(None)
        if not nodeids:
            return res_pre
        codes = []
        n = self.max_nodes["write"]
        with _faults("write"):
            for ids, values in zip(_chunks(nodeids, n), _chunks(dvs, n), strict=True):
                self.count("write")
                got = await client.uaclient.write_attributes(ids, values, ua.AttributeIds.Value)
                _answered(got, ids, "write")
                codes += got
        it = iter(codes)
        return [
            r
            if r is not None
            else (None if (code := next(it)).is_good() else f"status {code.name}")
            for r in res_pre
        ]


async def _pinned_mismatch(c: ConnectionConfig, expected: str) -> list[str]:
    """Why a secured connect failed, if the server presents another certificate than the pinned.

    A client that encrypts for the wrong certificate gets no answer (a bare
    timeout); the server's endpoints (GetEndpoints needs no security) show
    which certificate it really has.
    """
    import asyncio

    asyncua = _asyncua()
    try:
        probe = asyncua.Client(c.url, timeout=min(c.connect_timeout, 5.0))
        endpoints = await asyncio.wait_for(probe.connect_and_get_server_endpoints(), 5.0)
    except Exception:  # the server is not reachable at all: the original error stands
        return []
    certs = {fingerprint(bytes(e.ServerCertificate)) for e in endpoints if e.ServerCertificate}
    if not certs or expected in certs:
        return []
    got = sorted(certs)[0]
    return [
        f"the server's certificate (SHA-256 {got[:16]}...) is not the pinned "
        f"server_certificate {c.server_certificate} ({expected[:16]}...)"
    ]


def _chunks(items: list[Any], size: int) -> list[list[Any]]:
    """``items`` in chunks of at most ``size`` (``size`` 0: one chunk)."""
    if size <= 0 or len(items) <= size:
        return [items]
    return [items[i : i + size] for i in range(0, len(items), size)]


async def _operation_limits(client: Any) -> dict[str, int]:
    """The server's MaxNodesPerRead/MaxNodesPerWrite (0 where absent or unreadable)."""
    from asyncua import ua

    ids = [
        ua.NodeId(ua.ObjectIds.Server_ServerCapabilities_OperationLimits_MaxNodesPerRead),
        ua.NodeId(ua.ObjectIds.Server_ServerCapabilities_OperationLimits_MaxNodesPerWrite),
    ]
    out = {"read": 0, "write": 0}
    try:
        dvs = await client.uaclient.read_attributes(ids, ua.AttributeIds.Value)
    except Exception:  # a server without the nodes: no limit known
        log.debug("OPC UA: operation limits not readable", exc_info=True)
        return out
    for kind, dv in zip(("read", "write"), dvs, strict=True):
        v = dv.Value.Value if dv.Value is not None else None
        if (dv.StatusCode is None or dv.StatusCode.is_good()) and isinstance(v, int) and v > 0:
            out[kind] = int(v)
    return out


def _data_types() -> dict[int, Any]:
    try:
        from asyncua import ua
    except ImportError:  # pragma: no cover
        return {}
    V, O = ua.VariantType, ua.ObjectIds  # noqa: E741
    return {
        O.Boolean: V.Boolean,
        O.Float: V.Float,
        O.Double: V.Double,
        O.SByte: V.SByte,
        O.Byte: V.Byte,
        O.Int16: V.Int16,
        O.UInt16: V.UInt16,
        O.Int32: V.Int32,
        O.UInt32: V.UInt32,
        O.Int64: V.Int64,
        O.UInt64: V.UInt64,
    }


_DATA_TYPES = _data_types()


# ---------------------------------------------------------------------------
# Certificates and the trust list
# ---------------------------------------------------------------------------


def fingerprint(der: bytes) -> str:
    """SHA-256 fingerprint (hex) of a DER certificate."""
    return hashlib.sha256(der).hexdigest()


def _load_der(path: Path) -> bytes:
    from cryptography import x509
    from cryptography.hazmat.primitives.serialization import Encoding

    data = path.read_bytes()
    if b"-----BEGIN CERTIFICATE-----" in data:
        return x509.load_pem_x509_certificate(data).public_bytes(Encoding.DER)
    return data


def trust_list_validator(trusted: Iterable[str | Path]) -> Any:
    """A server-side certificate validator that accepts only the listed certificates.

    ``trusted`` are certificate files (DER or PEM) or directories of them.
    The client certificate must be one of them (SHA-256 fingerprint) and
    within its validity period; an empty list refuses every client.
    """
    prints: set[str] = set()
    for t in trusted:
        p = Path(t)
        files = sorted(p.glob("*")) if p.is_dir() else [p]
        for f in files:
            if f.suffix.lower() in (".der", ".pem", ".crt"):
                prints.add(fingerprint(_load_der(f)))

    async def validate(cert: Any, app_description: Any) -> None:
        from asyncua import ua
        from asyncua.common.utils import ServiceError
        from cryptography.hazmat.primitives.serialization import Encoding

        now = _dt.datetime.now(_dt.timezone.utc)
        if not (cert.not_valid_before_utc <= now <= cert.not_valid_after_utc):
            raise ServiceError(ua.StatusCodes.BadCertificateTimeInvalid)
        if fingerprint(cert.public_bytes(Encoding.DER)) not in prints:
            log.warning(
                "refused an untrusted client certificate (%s)", cert.subject.rfc4514_string()
            )
            raise ServiceError(ua.StatusCodes.BadCertificateUntrusted)

    validate.fingerprints = prints  # type: ignore[attr-defined]
    return validate


def make_certificate(
    cert_file: str | Path,
    key_file: str | Path,
    *,
    common_name: str,
    application_uri: str,
    server: bool = False,
    days: int = 365,
) -> None:
    """Write a self-signed OPC UA application certificate (DER) and its key (PEM).

    For tests and first setups; production certificates come from the site's
    certificate authority.  ``application_uri`` must equal the application's
    URI (OPC UA checks it against the certificate's subject alternative name).
    """
    _asyncua()
    import socket

    from asyncua.crypto.cert_gen import (
        dump_private_key_as_pem,
        generate_private_key,
        generate_self_signed_app_certificate,
    )
    from cryptography import x509
    from cryptography.hazmat.primitives.serialization import Encoding
    from cryptography.x509.oid import ExtendedKeyUsageOID

    key = generate_private_key()
    use = [ExtendedKeyUsageOID.SERVER_AUTH if server else ExtendedKeyUsageOID.CLIENT_AUTH]
    names = [
        x509.UniformResourceIdentifier(application_uri),
        x509.DNSName(socket.gethostname()),
        x509.DNSName("localhost"),
    ]
    cert = generate_self_signed_app_certificate(key, common_name, {}, names, use, days=days)
    Path(cert_file).write_bytes(cert.public_bytes(Encoding.DER))
    Path(key_file).write_bytes(dump_private_key_as_pem(key))
