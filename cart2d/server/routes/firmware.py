"""The firmware: its settings (read, write, EEPROM) and its update through the bootloader."""

from __future__ import annotations

from fastapi import APIRouter, HTTPException, Request

from cart2d.server.answers import Done, FirmwareSettingOut, SettingValueOut, UpdateOut
from cart2d.server.deps import GatewayDep, Guarded, SourceDep
from cart2d.server.models import SettingIn, errors, read_body

router = APIRouter(responses=errors(413))  # as the app's own routes (create_app)


@router.get(
    "/api/firmware/settings",
    summary="every firmware setting: id, name, unit, range, value",
    responses=errors(409, 503),
    response_model=list[FirmwareSettingOut],
)
def firmware_settings(source: SourceDep) -> list[dict[str, object]]:
    return source.firmware_settings()  # none in a replay


@router.put(
    "/api/firmware/settings",
    dependencies=[Guarded],
    summary="change one firmware setting",
    responses=errors(400, 401, 409, 422, 503),
)
def set_setting(body: SettingIn, gateway: GatewayDep) -> SettingValueOut:
    return SettingValueOut(value=gateway.write_setting(body.id, body.value))


@router.post(
    "/api/firmware/save",
    dependencies=[Guarded],
    summary="firmware settings to EEPROM",
    responses=errors(401, 409, 503),
)
def save(gateway: GatewayDep) -> Done:
    gateway.save_settings()
    return Done(result="saving")


@router.post(
    "/api/firmware/load",
    dependencies=[Guarded],
    summary="firmware settings from EEPROM",
    responses=errors(401, 409, 503),
)
def load(gateway: GatewayDep) -> Done:
    gateway.load_settings()
    return Done(result="loaded")


@router.post(
    "/api/firmware/update",
    dependencies=[Guarded],
    status_code=202,
    summary="upload an Intel HEX file: avrdude flashes it through the Nano's bootloader (simulated too)",
    description="409 with a sentence saying what to do when nothing can flash the robot on this link "
    "(rfc2217://, which avrdude does not speak; a simulator started with --no-bootloader) or an update "
    "is already running; 422 when the file is refused.",
    responses=errors(401, 409, 422),
    openapi_extra={
        "requestBody": {
            "required": True,
            "content": {"application/octet-stream": {"schema": {"type": "string", "format": "binary"}}},
        }
    },
    response_model=UpdateOut,
)
async def update_firmware(request: Request, gateway: GatewayDep) -> dict[str, object]:
    body = await read_body(request)
    try:
        return gateway.start_update(body)
    except ValueError as exc:
        raise HTTPException(422, str(exc)) from exc
    except RuntimeError as exc:
        raise HTTPException(409, str(exc)) from exc


@router.get("/api/firmware/update", summary="the firmware update's state and log", response_model=UpdateOut)
def update_state(gateway: GatewayDep) -> dict[str, object]:
    return gateway.update_view()
