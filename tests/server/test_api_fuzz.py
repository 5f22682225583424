"""Schema-driven fuzz of the whole HTTP API with schemathesis, against the real firmware in the simulator.

Every operation of /openapi.json gets generated requests: the coverage phase (boundary values, wrong
types, missing or malformed bodies, undeclared methods) and the fuzzing phase (schema-valid and
schema-violating data). They go through the ASGI app of a gateway whose link talks to the simulator,
so /api/reset, /api/stop, /api/goto and the generic command really act on the (simulated) robot.
Schemathesis's default checks apply to every response: no 5xx, documented status codes, content
types and headers, bodies matching their response schemas, schema-valid data accepted and
schema-violating data rejected, 405 with a matching Allow header for undeclared methods.
Afterwards the gateway must still be connected and the firmware answering.

Bounded and repeatable: a fixed seed with derandomized generation, at most MAX_EXAMPLES fuzzing
examples per operation (the coverage phase adds its own finite set), no example database, and
Hypothesis' other files under build/hypothesis.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Iterator
from typing import Any, cast

import pytest
import schemathesis
from hypothesis.configuration import set_hypothesis_home_dir
from schemathesis import Case
from schemathesis.config import SchemathesisConfig
from schemathesis.schemas import BaseSchema

from cart2d.link import firmware
from cart2d.server.guards import SAFE_METHODS
from cart2d.spec import load_spec, repo_file
from tests.support.server import BASE_URL, Rig
from tests.support.waiting import wait_for

# go under build/, not into a .hypothesis/ directory in the working tree.
set_hypothesis_home_dir(repo_file("build", "hypothesis"))

MAX_EXAMPLES = 30
SEED = 20261121

# Refusals that JSON Schema cannot express, answered 422 with a reason: a goal or an obstacle off
# the *current* map (which /api/settings/file changes at run time), blocked or unreachable; a pose
# beyond the current arena's walls; a settings file whose obstacles lie off its own grid; a HEX file
# with bad records or checksums; a map whose image or YAML cannot be read; a network host that is
# neither an IP address nor a host name (the schema's pattern gives only its characters); a camera
# URL whose bracketed IPv6 address is none (the pattern gives only its characters); a simulated box
# under the cart where it stands now. Only for these does positive_data_acceptance take 422 as well
# (its defaults, plus 422); every other check, including that the 422 is documented and its body
# matches the documented schema, applies as everywhere.
SEMANTIC_REFUSALS = [
    "POST /api/goto",
    "POST /api/pose",
    "PUT /api/map/obstacle",
    "POST /api/map",
    "POST /api/settings/file",
    "POST /api/firmware/update",
    "PUT /api/settings/network",
    "PUT /api/settings/camera",
    "POST /api/sim/boxes",  # a box under the cart, where the cart is now
]
POSITIVE_DATA_STATUSES = ["2xx", "3xx", "401", "403", "404", "409", "422", "429", "5xx"]
# Invalid requests are refused with schemathesis' defaults or 413: a body over the guards' limit
# (cart2d/server/guards.py, documented on every operation) is refused before it is parsed, as a
# generated array far over its maxItems is.
NEGATIVE_DATA_STATUSES = [
    "400",
    "401",
    "403",
    "404",
    "405",
    "406",
    "409",
    "413",
    "415",
    "422",
    "428",
    "429",
    "5xx",
]

CONFIG: dict[str, Any] = {
    # The gateway answers only to its own Host (cart2d/server/guards.py): requests go to the address
    # a browser on this machine uses, not to the test client's "testserver".
    "base-url": BASE_URL,
    "seed": SEED,
    "generation": {
        "max-examples": MAX_EXAMPLES,
        "deterministic": True,  # Hypothesis' derandomize: the same requests on every run
        "database": "none",  # no example database: nothing is replayed from earlier runs
    },
    "checks": {"negative_data_rejection": {"expected-statuses": NEGATIVE_DATA_STATUSES}},
    "operations": [
        {
            "include-name": SEMANTIC_REFUSALS,
            "checks": {"positive_data_acceptance": {"expected-statuses": POSITIVE_DATA_STATUSES}},
        }
    ],
}

# Requests sent, by (operation, phase), for the check that follows the fuzz.
SENT: Counter[tuple[str, str]] = Counter()


@pytest.fixture(scope="module")
def rig(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Rig]:
    r = Rig(tmp_path_factory.mktemp("api-fuzz"))
    yield r
    r.close()


@pytest.fixture(scope="module")
def app_schema(rig: Rig) -> BaseSchema:
    config = SchemathesisConfig.from_dict(CONFIG)
    return schemathesis.openapi.from_asgi(
        "/openapi.json", rig.client.app, config=config, headers={"host": BASE_URL.split("://", 1)[1]}
    )


@pytest.fixture
def api_schema(app_schema: BaseSchema, request: pytest.FixtureRequest) -> BaseSchema:
    # schemathesis 4.32's lazy loader reads and rewrites `request.node._nodeid` to label each
    # operation; pytest 9.2 keeps the node id elsewhere (`_id`), so give the node the attribute.
    if not hasattr(request.node, "_nodeid"):
        setattr(request.node, "_nodeid", request.node.nodeid)  # noqa: B010 (not a typed attribute)
    return app_schema


schema = schemathesis.pytest.from_fixture("api_schema")
parametrize = cast(Callable[[Callable[..., None]], Callable[..., None]], schema.parametrize())


@parametrize
def test_every_operation_with_generated_requests(case: Case[Any], rig: Rig) -> None:
    phase = case.meta.phase.name.value if case.meta is not None else "explicit"
    SENT[(case.operation.label, phase)] += 1
    if (
        case.method.upper() not in SAFE_METHODS
        and case.media_type is None
        and "content-type" not in case.headers
    ):
        # A change without a body is still sent as JSON, as the panel sends it: the guards refuse a
        # change in any type a cross-origin form or beacon could carry (415, tested in test_web_guards).
        case.headers["Content-Type"] = "application/json"
    if case.media_type == "multipart/form-data":
        # A form is taken only with proof that no page elsewhere sent it (SECURITY.md): curl's
        # X-Cart2d-Token header, any value on loopback. Without it every form is a 403.
        case.headers["X-Cart2d-Token"] = "fuzz"
    try:
        case.call_and_validate()
    finally:
        if case.operation.label == "PUT /api/sim/faults":
            # A fault is what the simulator is asked for: dropped or corrupted bytes on the serial
            # line would fail the operations after this one (503, as on a bad cable). Off again.
            rig.sim.set_faults({})


def test_the_gateway_still_works_after_the_fuzz(rig: Rig) -> None:
    if not SENT:
        pytest.skip("the fuzz did not run (deselected)")
    total = sum(SENT.values())
    operations = {label for label, _ in SENT}
    print(f"\nAPI fuzz: {total} requests over {len(operations)} operations")
    for (label, phase), count in sorted(SENT.items()):
        print(f"  {label:32} {phase:9} {count}")

    def connected() -> bool:
        status = rig.client.get("/api/status").json()
        return bool(status["link"]["state"] == "connected" and "error" not in status["link"])

    wait_for(connected, 10)  # a fuzzed /api/reset may still be restarting the MCU
    status = rig.client.get("/api/status")
    assert status.status_code == 200
    body = status.json()
    assert body["link"]["state"] == "connected"
    assert body["status"]["mode"] in load_spec().modes.values()  # the firmware answered STATUS
    # The firmware answers a command sent through the API, and directly on the link, as the same build.
    pose = rig.client.post("/api/command", json={"name": "POSE", "args": []})
    assert pose.status_code == 200 and pose.json()["status"] == "CONTROL_OK"
    assert firmware.read_version(rig.link) == rig.gateway.version
    assert rig.client.post("/api/stop").status_code == 200
