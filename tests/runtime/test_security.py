"""OPC UA security: Basic256Sha256 SignAndEncrypt, user/password, certificate trust lists."""

from __future__ import annotations

import asyncio
import dataclasses

import pytest

from ctrlblocks.runtime import ConnectionConfig, IOFault, PlantServer
from ctrlblocks.runtime.opcua import OpcUaAdapter, make_certificate, trust_list_validator
from ctrlblocks.sim import PlantProcess, load_scenario

from .conftest import DATA

pytestmark = pytest.mark.loopback

CLIENT_URI = "urn:ctrlblocks:runtime"


@pytest.fixture(scope="module")
def pki(tmp_path_factory):
    d = tmp_path_factory.mktemp("pki")
    make_certificate(
        d / "server.der",
        d / "server.pem",
        common_name="plant",
        application_uri="urn:plant",
        server=True,
    )
    make_certificate(
        d / "client.der", d / "client.pem", common_name="rt", application_uri=CLIENT_URI
    )
    make_certificate(
        d / "intruder.der", d / "intruder.pem", common_name="rt", application_uri=CLIENT_URI
    )
    (d / "trusted").mkdir()
    (d / "trusted" / "client.der").write_bytes((d / "client.der").read_bytes())
    return d


def client_config(pki, url, **kw):
    base = ConnectionConfig(
        name="plant",
        protocol="opcua",
        url=url,
        timeout=2.0,
        security="Basic256Sha256_SignAndEncrypt",
        certificate=str(pki / "client.der"),
        private_key=str(pki / "client.pem"),
        server_certificate=str(pki / "server.der"),
        user="operator",
        password="s3cret",
        application_uri=CLIENT_URI,
    )
    return dataclasses.replace(base, **kw)


def test_trust_list_holds_exactly_the_listed_certificates(pki):
    v = trust_list_validator([pki / "trusted"])
    assert len(v.fingerprints) == 1
    assert trust_list_validator([]).fingerprints == set()  # empty: nobody is trusted


async def plaintext_session(url: str) -> str:
    """Open a session over an unencrypted channel, skipping the client's endpoint check.

    The attack a careless client (or an attacker) makes: SecurityPolicy None,
    user and password in clear.  Returns "read <value>" or the refusal.
    """
    from asyncua import Client, ua

    c = Client(url, timeout=2.0)
    try:
        await c.connect_socket()
        await c.send_hello()
        await c.open_secure_channel()
        params = ua.CreateSessionParameters(
            ClientNonce=b"0" * 32,
            ClientDescription=ua.ApplicationDescription(
                ApplicationUri="urn:plain", ApplicationType=ua.ApplicationType.Client
            ),
            EndpointUrl=url,
            SessionName="plain",
            RequestedSessionTimeout=60000,
        )
        await c.uaclient.create_session(params)
        token = ua.UserNameIdentityToken(
            UserName="operator", Password=b"s3cret", PolicyId="username"
        )
        await c.uaclient.activate_session(
            ua.ActivateSessionParameters(UserIdentityToken=token, LocaleIds=["en"])
        )
        value = await c.get_node("ns=2;s=pv").read_value()
        return f"read {value}"
    except Exception as exc:
        return f"refused: {exc}"
    finally:
        c.disconnect_socket()


def test_plaintext_session_attack_works_on_an_open_server(opcua_plant):
    """Control for the next test: the same unencrypted session reads an unsecured server."""
    from ctrlblocks.sim import PlantProcess as PP

    from .conftest import fresh

    server = fresh(*opcua_plant, PP(load_scenario(DATA / "pid_pt2.toml")))
    assert asyncio.run(plaintext_session(server.opcua_url)).startswith("read ")


def test_secured_server_accepts_only_trusted_encrypted_authenticated_clients(pki):
    sc = load_scenario(DATA / "pid_pt2.toml")

    async def attempt(cfg):
        a = OpcUaAdapter(cfg)
        try:
            await a.connect()
        except IOFault as exc:
            return str(exc)
        try:
            (r,) = await a.read(["ns=2;s=pv"])
            return r
        finally:
            await a.close()

    async def main():
        server = PlantServer(
            PlantProcess(sc),
            opcua_port=0,
            modbus_port=None,
            certificate=pki / "server.der",
            private_key=pki / "server.pem",
            trusted=[pki / "trusted"],
            users={"operator": "s3cret"},
        )
        await server.start()
        url = server.opcua_url
        try:
            good = await attempt(client_config(pki, url))
            wrong_pw = await attempt(client_config(pki, url, password="guess"))
            untrusted = await attempt(
                client_config(
                    pki,
                    url,
                    certificate=str(pki / "intruder.der"),
                    private_key=str(pki / "intruder.pem"),
                )
            )
            plain = await attempt(
                client_config(
                    pki,
                    url,
                    security="none",
                    certificate=None,
                    private_key=None,
                    server_certificate=None,
                )
            )
            fake_server = await attempt(
                client_config(
                    pki,
                    url,
                    server_certificate=str(pki / "intruder.der"),
                    timeout=0.5,
                    connect_timeout=2.0,
                )
            )
            raw = await plaintext_session(url)
        finally:
            await server.stop()
        return good, wrong_pw, untrusted, plain, fake_server, raw

    good, wrong_pw, untrusted, plain, fake_server, raw = asyncio.run(main())
    # the positive control: the trusted, encrypted, authenticated client reads the PV
    assert good.ok and good.value == pytest.approx(1.0)  # PT2 k = 2 at u0 = 0.5
    assert "BadUserAccessDenied" in wrong_pw
    assert "BadCertificateUntrusted" in untrusted
    assert "No matching endpoints" in plain  # the server offers no unencrypted endpoint
    assert "BadUserAccessDenied" in raw  # and refuses a session forced over one
    # a client given another server certificate cannot talk to this server
    assert fake_server.startswith("OPC UA connect")
    # and the error says why (it was a bare TimeoutError)
    assert "is not the pinned server_certificate" in fake_server and "intruder.der" in fake_server
