"""The console's login, sessions, roles and CSRF (issue 29), over plain HTTP (no browser):
without a session the pages send a browser to the login page and the rest answers 401; a
customer sees only its own requests and no staff page; a form without its CSRF token is
refused and changes nothing; logging out (or revoking the token) ends the session."""

from __future__ import annotations

import contextlib
import itertools
import re
from collections.abc import AsyncIterator

import httpx
import pytest
from conftest import MakeFleet
from fleet_harness import Fleet, alerts, loaded, offline, token_for

from fleet.api.schemas import RequestOut
from fleet.console.customer import customer_actions
from fleet.console.staff_pages import staff_actions
from fleet.status import ALLOWED, Action, Status

CSRF = re.compile(r'name="csrf" value="([^"]+)"')


def browser(fleet: Fleet, scheme: str = "http") -> httpx.AsyncClient:
    """A client with a cookie jar and no bearer token, as a browser is."""
    return httpx.AsyncClient(transport=httpx.ASGITransport(app=fleet.app),
                             base_url=f"{scheme}://fleet")


def csrf_of(page: str) -> str:
    found = CSRF.search(page)
    assert found is not None, page
    return found.group(1)


async def log_in(client: httpx.AsyncClient, role: str, subject: str) -> httpx.Response:
    form = await client.get("/login")
    assert form.status_code == 200
    return await client.post("/login", data={"csrf": csrf_of(form.text),
                                             "token": token_for(role, subject)})


@contextlib.asynccontextmanager
async def logged_in(fleet: Fleet, role: str, subject: str
                    ) -> AsyncIterator[tuple[httpx.AsyncClient, str]]:
    """A browser logged in as this caller, and the CSRF token of its session."""
    async with browser(fleet) as client:
        response = await log_in(client, role, subject)
        assert response.status_code == 303, response.text
        home = await client.get(response.headers["location"])
        assert home.status_code == 200, home.text
        yield client, csrf_of(home.text)


@pytest.fixture
async def fleet(make_fleet: MakeFleet) -> Fleet:
    return await make_fleet(AutoAccept=False)


class TestWithoutASession:
    async def test_pages_send_the_browser_to_the_login_page(self, fleet: Fleet) -> None:
        """GET / and /me answer 303 to /login; the login page is a form."""
        async with browser(fleet) as client:
            for path in ("/", "/me"):
                response = await client.get(path)
                assert response.status_code == 303
                assert response.headers["location"] == "/login"
            login = await client.get("/login")
            assert login.status_code == 200
            assert 'name="token"' in login.text

    async def test_fragments_and_forms_answer_401(self, fleet: Fleet) -> None:
        """Console fragments, form posts and the event stream need a session (or a token)."""
        async with browser(fleet) as client:
            for path in ("/console/board", "/console/robots", "/console/alerts", "/me/status",
                         "/me/requests/1"):
                assert (await client.get(path)).status_code == 401, path
            for path in ("/console/requests/1/accept", "/console/alerts/1/acknowledge",
                         "/me/request", "/logout"):
                assert (await client.post(path, data={"csrf": "x"})).status_code == 401
            client.cookies.set("fleet_session", "not-a-session")
            assert (await client.get("/api/events")).status_code == 401
            assert (await client.get("/")).headers["location"] == "/login"


class TestLogin:
    async def test_a_token_becomes_a_strict_http_only_session_cookie(self, fleet: Fleet) -> None:
        """The staff land on the console, customers on /me; the cookie is HttpOnly and
        SameSite=Strict, Secure only over TLS."""
        async with browser(fleet) as client:
            response = await log_in(client, "admin", "staff")
            assert response.status_code == 303
            assert response.headers["location"] == "/"
            cookie = next(c for c in response.headers.get_list("set-cookie")
                          if c.startswith("fleet_session="))
            assert "HttpOnly" in cookie
            assert "SameSite=strict" in cookie
            assert "Secure" not in cookie
        async with browser(fleet, "https") as client:
            response = await log_in(client, "customer", "1")
            assert response.headers["location"] == "/me"
            cookie = next(c for c in response.headers.get_list("set-cookie")
                          if c.startswith("fleet_session="))
            assert "Secure" in cookie

    async def test_bad_tokens_and_robots_do_not_get_a_session(self, fleet: Fleet) -> None:
        """An unknown token is 401, a robot's token 403, a login form without its own CSRF
        token 403; none sets a session cookie."""
        async with browser(fleet) as client:
            form = await client.get("/login")
            bad = await client.post("/login", data={"csrf": csrf_of(form.text),
                                                    "token": "x" * 40})
            assert bad.status_code == 401
            form = await client.get("/login")
            robot = await client.post("/login", data={"csrf": csrf_of(form.text),
                                                      "token": token_for("robot", "robot-1")})
            assert robot.status_code == 403
            forged = await client.post("/login", data={
                "csrf": "forged", "token": token_for("admin", "staff")})
            assert forged.status_code == 403
            assert "fleet_session" not in client.cookies


class TestRoles:
    async def test_a_customer_sees_no_staff_page(self, fleet: Fleet) -> None:
        async with logged_in(fleet, "customer", "1") as (client, _):
            for path in ("/", "/console/board", "/console/robots", "/console/alerts"):
                assert (await client.get(path)).status_code == 403, path

    async def test_staff_have_no_customer_page(self, fleet: Fleet) -> None:
        async with logged_in(fleet, "admin", "staff") as (client, _):
            assert (await client.get("/me")).status_code == 403

    async def test_a_customer_cannot_see_or_touch_anothers_request(self, fleet: Fleet) -> None:
        """Bob's request is 403 to Alice, in the page and its actions, and not on her page."""
        bobs = (await fleet.request(2))["Id"]
        async with logged_in(fleet, "customer", "1") as (client, csrf):
            assert (await client.get(f"/me/requests/{bobs}")).status_code == 403
            cancel = await client.post(f"/me/requests/{bobs}/cancel", data={"csrf": csrf})
            assert cancel.status_code == 403
            assert f"request-{bobs}" not in (await client.get("/me/status")).text
        assert await fleet.status(bobs) == "Pending"


class TestCsrf:
    async def test_a_form_without_its_token_is_refused_and_changes_nothing(
            self, fleet: Fleet) -> None:
        """403 without the token or with another's; then the right one works."""
        async with logged_in(fleet, "customer", "1") as (client, csrf):
            assert (await client.post("/me/request")).status_code == 403
            assert (await client.post("/me/request", data={"csrf": "x" + csrf})).status_code \
                == 403
            assert (await fleet.http.get("/api/requests")).json() == []
            made = await client.post("/me/request", data={"csrf": csrf})
            assert made.status_code == 303
        [request] = (await fleet.http.get("/api/requests")).json()
        async with logged_in(fleet, "admin", "staff") as (staff, staff_csrf):
            accept = f"/console/requests/{request['Id']}/accept"
            assert (await staff.post(accept, data={"csrf": csrf})).status_code == 403
            assert await fleet.status(request["Id"]) == "Pending"
            assert (await staff.post(accept, data={"csrf": staff_csrf})).status_code == 303
        assert await fleet.status(request["Id"]) == "Accepted"


class TestStaffForms:
    async def test_an_action_out_of_turn_shows_the_reason(self, fleet: Fleet) -> None:
        """409 from the service is the console page with its message."""
        request = await fleet.request(1)
        await fleet.do(request["Id"], "decline")
        async with logged_in(fleet, "admin", "staff") as (client, csrf):
            response = await client.post(f"/console/requests/{request['Id']}/accept",
                                         data={"csrf": csrf})
            assert response.status_code == 409
            assert "cannot accept request" in response.text
            assert 'id="board"' in response.text

    async def test_the_board_shows_the_actions_each_status_allows(self, fleet: Fleet) -> None:
        request = await fleet.request(1)
        async with logged_in(fleet, "admin", "staff") as (client, _):
            row = (await client.get("/console/board")).text
            for action in ("accept", "decline", "cancel"):
                assert f'data-action="{action}"' in row
            assert 'data-action="washing-done"' not in row
            await fleet.do(request["Id"], "accept")
            row = (await client.get("/console/board")).text
            assert 'data-action="accept"' not in row
            assert 'data-action="cancel"' in row


class TestLogout:
    async def test_logging_out_revokes_the_session(self, fleet: Fleet) -> None:
        """The old cookie is refused after logout, even if a browser kept it."""
        async with logged_in(fleet, "admin", "staff") as (client, csrf):
            cookie = client.cookies["fleet_session"]
            response = await client.post("/logout", data={"csrf": csrf})
            assert response.status_code == 303
            assert response.headers["location"] == "/login"
            client.cookies.set("fleet_session", cookie)
            assert (await client.get("/")).status_code == 303
            assert (await client.get("/console/board")).status_code == 401

    async def test_revoking_the_token_ends_its_sessions(self, fleet: Fleet) -> None:
        async with logged_in(fleet, "customer", "1") as (client, _):
            tokens = (await fleet.http.get("/api/tokens")).json()
            token_id = next(t["Id"] for t in tokens if t["Role"] == "customer"
                            and t["Subject"] == "1")
            assert (await fleet.http.delete(f"/api/tokens/{token_id}")).status_code == 200
            assert (await client.get("/me/status")).status_code == 401


class TestAlertForms:
    async def test_staff_acknowledge_and_resolve_a_laundry_alert_saying_where_it_is(
            self, make_fleet: MakeFleet) -> None:
        """A robot offline with laundry: acknowledged from the console, refused without
        LaundryAt (422, the reason on the page), resolved with the laundry at base."""
        fleet = await make_fleet()
        request_id = await loaded(fleet)
        await offline(fleet)
        [alert] = await alerts(fleet, open="true")
        async with logged_in(fleet, "admin", "staff") as (client, csrf):
            shown = (await client.get("/console/alerts")).text
            assert f'id="alert-{alert["Id"]}"' in shown
            assert 'name="LaundryAt"' in shown
            base = f"/console/alerts/{alert['Id']}"
            assert (await client.post(f"{base}/acknowledge", data={"csrf": csrf})
                    ).status_code == 303
            assert "seen by staff" in (await client.get("/console/alerts")).text
            refused = await client.post(f"{base}/resolve", data={"csrf": csrf})
            assert refused.status_code == 422
            assert "LaundryAt" in refused.text
            resolved = await client.post(f"{base}/resolve",
                                         data={"csrf": csrf, "LaundryAt": "base"})
            assert resolved.status_code == 303
            assert "No open alerts" in (await client.get("/console/alerts")).text
        assert await fleet.status(request_id) == "Washing"

    async def test_a_fault_alert_is_resolved_without_laundry(self, make_fleet: MakeFleet
                                                             ) -> None:
        fleet = await make_fleet()
        await fleet.exchange("robot-2", Fault={"Code": "bumper", "Message": "pressed"})
        [alert] = await alerts(fleet, open="true")
        async with logged_in(fleet, "admin", "staff") as (client, csrf):
            robots = (await client.get("/console/robots")).text
            assert "bumper: pressed" in robots
            assert 'name="LaundryAt"' not in (await client.get("/console/alerts")).text
            assert (await client.post(f"/console/alerts/{alert['Id']}/resolve",
                                      data={"csrf": csrf})).status_code == 303
        assert await alerts(fleet, open="true") == []


class TestButtons:
    def test_every_button_shown_is_an_action_the_status_allows(self) -> None:
        """For every status and flag, the board's and the phone page's buttons are a subset
        of fleet.status.ALLOWED (a button never leads to a 409 by itself)."""
        for status in Status:
            for approved, paid, queued, loadable, unloadable in itertools.product(
                    (False, True), repeat=5):
                request = RequestOut.model_validate(_request(
                    status, IsApproved=approved, IsPaid=paid, DeliveryQueued=queued,
                    CanConfirmLoaded=loadable and status == Status.ARRIVED_AT_ROOM,
                    CanConfirmUnloaded=unloadable and status == Status.ARRIVED_FOR_DELIVERY))
                for action in [*staff_actions(request), *customer_actions(request)]:
                    assert status in ALLOWED[action], (status, action)
                if status == Status.PENDING and not approved:
                    assert Action.ACCEPT in staff_actions(request)
                if paid:
                    assert Action.PAY not in customer_actions(request)


def _request(status: Status, **fields: object) -> dict[str, object]:
    return {"Id": 1, "CustomerId": 1, "Status": str(status), "AssignedRobotName": None,
            "CreatedAt": "2026-01-05T08:00:00Z", "StatusChangedAt": "2026-01-05T08:00:00Z",
            "RefundDue": False, "CancelReason": None, "CancelledFrom": None,
            "LaundryDisposition": "None", "RobotReturned": False, "WeightKg": None,
            "Overweight": False, "AdminAlert": None, "Refund": None, **fields}


class TestSeveralProcesses:
    async def test_a_session_opened_on_one_server_works_on_another(
            self, make_fleet: MakeFleet) -> None:
        """Two servers on one database (as behind a load balancer): a session opened on one
        is known to the other, and logging out on the other ends it on both."""
        first, second = await make_fleet(), await make_fleet()
        async with logged_in(first, "admin", "staff") as (client, csrf):
            cookie = client.cookies["fleet_session"]
        async with browser(second) as other:
            other.cookies.set("fleet_session", cookie)
            assert (await other.get("/")).status_code == 200
            assert (await other.post("/logout", data={"csrf": csrf})).status_code == 303
        async with browser(first) as again:
            again.cookies.set("fleet_session", cookie)
            assert (await again.get("/console/board")).status_code == 401


class TestLoginLimit:
    async def test_an_address_that_failed_too_often_gets_429_even_with_a_good_token(
            self, db_url: str) -> None:
        """The API's failure limit holds for the login form too (a guess that hits must not
        be told apart)."""
        async with Fleet(db_url, auth_failures_per_min=2) as fleet, browser(fleet) as client:
            for _ in range(2):
                form = await client.get("/login")
                response = await client.post("/login", data={"csrf": csrf_of(form.text),
                                                              "token": "y" * 40})
                assert response.status_code == 401
            assert (await log_in(client, "admin", "staff")).status_code == 429
