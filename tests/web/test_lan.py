"""`serve --lan`: a plan's files handed to a phone or a DJI remote controller on the local network.

The app is driven as two machines would: this one (a loopback client address) and another on
the network (a private address). Only a file the page shared answers the other machine; its
QR code is read back with zxing-cpp (an independent decoder, not the encoder that made it).
"""

from __future__ import annotations

import base64
import io

import pytest
import zxingcpp
from click.testing import CliRunner
from PIL import Image
from starlette.testclient import TestClient
from webutil import copy_mission, run_plan

from aerosurvey.cli import main
from aerosurvey.web.app import create_app

LAN = "192.168.7.20:8765"
LOCAL = ("127.0.0.1", 50000)
PHONE = ("192.168.7.31", 50000)


@pytest.fixture(scope="module")
def shared(tmp_path_factory):
    spec = copy_mission(tmp_path_factory.mktemp("lan"))
    app = create_app(spec, allowed_hosts=["127.0.0.1:8765"], lan=LAN)
    with TestClient(app, base_url="http://127.0.0.1:8765", client=LOCAL) as here, \
            TestClient(app, base_url=f"http://{LAN}", client=PHONE) as phone:
        st = here.get("/api/state").json()
        assert st["lan"] is True
        done = run_plan(here, st["spec"])
        assert done["state"] == "done", done
        yield {"here": here, "phone": phone, "plan": done["result"]}


def _decode(png_b64: str) -> list[str]:
    return [r.text for r in zxingcpp.read_barcodes(Image.open(io.BytesIO(base64.b64decode(png_b64))))]


def test_a_shared_sortie_file_reaches_the_phone_by_its_qr_code(shared):
    here, phone, plan = shared["here"], shared["phone"], shared["plan"]
    name = next(f for f in plan["files"] if f.startswith("sortie-") and f.endswith(".plan"))
    r = here.post(f"/api/plans/{plan['plan_id']}/share/{name}", headers={"Origin": "http://127.0.0.1:8765"})
    assert r.status_code == 200, r.text
    url = r.json()["url"]
    assert url.startswith(f"http://{LAN}/lan/") and url.endswith(f"/{name}")
    assert _decode(r.json()["qr_png"]) == [url]  # the QR code says the URL, read by another decoder
    got = phone.get(url.removeprefix(f"http://{LAN}"))
    assert got.status_code == 200 and got.content == here.get(f"/api/plans/{plan['plan_id']}/files/{name}").content
    assert name in got.headers["content-disposition"]
    # a second share is another address; an address guessed or of another file is not served
    again = here.post(f"/api/plans/{plan['plan_id']}/share/{name}").json()["url"]
    assert again != url
    token = url.split("/")[-2]
    assert phone.get(f"/lan/{token}/mission.plan").status_code == 404
    assert phone.get(f"/lan/{'A' * 22}/{name}").status_code == 404


def test_the_phone_reaches_nothing_else(shared):
    phone, plan = shared["phone"], shared["plan"]
    pid = plan["plan_id"]
    for method, path in [("GET", "/"), ("GET", "/api/state"), ("GET", f"/api/plans/{pid}/files/mission.plan"),
                         ("GET", f"/api/plans/{pid}/archive.zip"), ("POST", f"/api/plans/{pid}/share/mission.plan"),
                         ("POST", "/api/plan"), ("GET", "/static/app.js")]:
        r = phone.request(method, path)
        assert r.status_code == 403 and "only files shared" in r.json()["error"], (method, path, r.status_code)


def test_sharing_keeps_the_origin_rule_and_needs_lan(shared, tmp_path):
    here, plan = shared["here"], shared["plan"]
    r = here.post(f"/api/plans/{plan['plan_id']}/share/mission.plan", headers={"Origin": "http://evil.example"})
    assert r.status_code == 403
    assert here.post(f"/api/plans/{plan['plan_id']}/share/nope.txt").status_code == 404
    plain = create_app(copy_mission(tmp_path))
    with TestClient(plain, client=LOCAL) as c:
        assert c.get("/api/state").json()["lan"] is False
        r = c.post("/api/plans/p1/share/mission.plan")
        assert r.status_code == 404 and "serve --lan" in r.json()["error"]


def test_serve_lan_refuses_what_it_cannot_do(tmp_path):
    spec = copy_mission(tmp_path)
    for args, words in [(["--lan-address", "192.168.1.2"], "without --lan"),
                        (["--lan", "--host", "0.0.0.0"], "--lan with --host"),
                        (["--lan", "--lan-address", "phone"], "--lan-address = 'phone' is not allowed")]:
        res = CliRunner().invoke(main, ["serve", str(spec), *args])
        assert res.exit_code == 2 and words in res.output, (args, res.output)
