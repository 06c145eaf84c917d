"""Answers the OpenAPI document promises: one 4xx body, 422 for undecodable bodies, OPTIONS
and 405 with a complete Allow, integer-valued floats taken as integers."""

from __future__ import annotations

import pytest

from fleet.api.schemas import ErrorOut


class TestErrorBodies:
    async def test_a_422_names_each_bad_field_and_matches_the_document(self, fleet):
        response = await fleet.http.post("/api/requests", json={"CustomerId": "one"})
        assert response.status_code == 422
        body = ErrorOut.model_validate(response.json())
        assert body.detail.startswith("body.CustomerId:")
        assert body.errors is not None and body.errors[0].loc == ["body", "CustomerId"]

    @pytest.mark.parametrize("content", [b'{"CustomerId": 1', b'{"CustomerId": "\xff"}'],
                             ids=["truncated", "not-utf8"])
    async def test_an_undecodable_body_is_422_not_400(self, fleet, content):
        response = await fleet.http.post("/api/requests", content=content,
                                         headers={"content-type": "application/json"})
        assert response.status_code == 422
        assert ErrorOut.model_validate(response.json()).detail

    async def test_every_4xx_of_the_document_is_the_one_error_body(self, fleet):
        document = (await fleet.http.get("/openapi.json")).json()
        for path, item in document["paths"].items():
            for method, operation in item.items():
                for code, answer in operation["responses"].items():
                    if code.startswith("4"):
                        schema = answer["content"]["application/json"]["schema"]
                        assert schema == {"$ref": "#/components/schemas/ErrorOut"}, \
                            (method, path, code)


class TestMethods:
    async def test_options_lists_every_method_of_the_path(self, fleet):
        response = await fleet.http.options("/api/robots")
        assert response.status_code == 204
        assert response.headers["allow"] == "GET, OPTIONS, POST"
        response = await fleet.http.options("/api/robots/robot-1")
        assert response.headers["allow"] == "GET, OPTIONS, PATCH"

    async def test_a_method_the_path_does_not_take_is_405_with_allow(self, fleet):
        response = await fleet.http.delete("/api/robots")
        assert response.status_code == 405
        assert response.headers["allow"] == "GET, OPTIONS, POST"
        assert "DELETE" in response.json()["detail"]


class TestWholeNumbers:
    async def test_an_integer_valued_float_is_an_integer(self, fleet):
        response = await fleet.http.post("/api/requests", content=b'{"CustomerId": 1.0}',
                                         headers={"content-type": "application/json"})
        assert response.status_code == 201
        assert response.json()["CustomerId"] == 1

    @pytest.mark.parametrize("value", [b"1.5", b"true", b'"1"'])
    async def test_fractions_booleans_and_strings_are_not(self, fleet, value):
        response = await fleet.http.post("/api/requests", content=b'{"CustomerId": ' + value
                                         + b"}", headers={"content-type": "application/json"})
        assert response.status_code == 422


class TestTheRobotsName:
    """Schemathesis (ST202) found that the document did not say a data exchange body's
    RobotName must be the URL's (issue 28): it says so now, and the answer is as said."""

    async def test_the_document_says_the_body_names_the_robot_of_the_url(self, fleet):
        document = (await fleet.http.get("/openapi.json")).json()
        operation = document["paths"]["/api/Robot/{RobotName}/data-exchange"]["post"]
        assert "must be the same name" in operation["description"]
        assert "RobotName is not the path's" in operation["responses"]["422"]["description"]
        field = document["components"]["schemas"]["DataExchangeIn"]["properties"]["RobotName"]
        assert "must equal the path's RobotName" in field["description"]

    async def test_a_body_naming_another_robot_is_422_and_says_which(self, fleet):
        response = await fleet.http.post("/api/Robot/robot-1/data-exchange",
                                         json={"RobotName": "robot-2"})
        assert response.status_code == 422
        assert ErrorOut.model_validate(response.json()).detail == (
            "RobotName 'robot-2' in the body does not match 'robot-1' in the URL")
        ok = await fleet.http.post("/api/Robot/robot-1/data-exchange",
                                   json={"RobotName": "robot-1"})
        assert ok.status_code == 200
