"""OPC UA client adapter (asyncua) and the security helpers shared with the plant server.

Addresses are node ids as OPC UA writes them (``ns=2;s=pv``, ``ns=3;i=1001``).
The adapter reads all addresses of a cycle in one Read service call and
writes in one Write call.

Float vs double: the data type of each node is read once, at its first use;
values are written as a Variant of that type (``Float`` nodes get a FLOAT32,
``Double`` nodes a FLOAT64, integer nodes a rounded integer), because a
server may refuse a write whose Variant type differs from the node's
(``BadTypeMismatch``).  Reads of any numeric type come back as Python floats.

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


class OpcUaAdapter(Adapter):
    """OPC UA client (see the module docstring)."""

    def __init__(self, config: ConnectionConfig) -> None:
        self.config = config
        self._client: Any = None
        self._types: dict[str, Any] = {}  # address -> VariantType of the node
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
        client = asyncua.Client(c.url, timeout=c.timeout, watchdog_intervall=max(c.timeout, 1.0))
        client.application_uri = c.application_uri
        if c.security != "none":
            await client.set_security(
                SecurityPolicyBasic256Sha256,
                certificate=c.certificate,
                private_key=c.private_key,
                server_certificate=c.server_certificate,
                mode=ua.MessageSecurityMode.SignAndEncrypt,
            )
            expected = fingerprint(Path(c.server_certificate).read_bytes())  # type: ignore[arg-type]

            async def check_server(cert: Any, app: Any) -> None:
                from asyncua.common.utils import ServiceError
                from cryptography.hazmat.primitives.serialization import Encoding

                if fingerprint(cert.public_bytes(Encoding.DER)) != expected:
                    raise ServiceError(ua.StatusCodes.BadCertificateUntrusted)

            client.certificate_validator = check_server
        if c.user is not None:
            client.set_user(c.user)
            client.set_password(c.password or "")
        try:
            await client.connect()
        except Exception as exc:
            with contextlib.suppress(Exception):
                await client.disconnect()
            raise IOFault(f"OPC UA connect {c.url}: {describe(exc)}") from exc
        self._client = client
        self._types = {}

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

    async def _variant_types(self, addresses: Iterable[str]) -> None:
        from asyncua import ua

        client = self._live()
        new = [a for a in addresses if a not in self._types]
        if not new:
            return
        nodes = [client.get_node(a) for a in new]
        dvs = await client.read_attributes(nodes, ua.AttributeIds.DataType)
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
            nodes = [client.get_node(a) for a in addresses]
        except Exception as exc:  # a malformed node id
            return [bad(f"bad node id: {exc}")] * len(addresses)
        with _faults("read"):
            dvs = await client.read_attributes(nodes, ua.AttributeIds.Value)
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
            if vt not in (ua.VariantType.Float, ua.VariantType.Double):
                if not math.isfinite(x):
                    res_pre.append(f"{a}: {x!r} does not fit an integer node")
                    continue
                x = round(x)
            nodeids.append(client.get_node(a).nodeid)
            dvs.append(ua.DataValue(ua.Variant(x, vt)))
            res_pre.append(None)
        if not nodeids:
            return res_pre
        with _faults("write"):
            codes = await client.uaclient.write_attributes(nodeids, dvs, ua.AttributeIds.Value)
        it = iter(codes)
        return [
            r
            if r is not None
            else (None if (code := next(it)).is_good() else f"status {code.name}")
            for r in res_pre
        ]


def _data_types() -> dict[int, Any]:
    try:
        from asyncua import ua
    except ImportError:  # pragma: no cover
        return {}
    V, O = ua.VariantType, ua.ObjectIds  # noqa: E741
    return {
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
