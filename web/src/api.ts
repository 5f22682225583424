// The gateway's API (cart2d/server/, GET /openapi.json): the shapes the panel reads, and one
// fetch wrapper that turns every failure into a sentence a person can act on. The /ws messages
// are generated from their models (cart2d/gateway/messages.py, `make ws-types`): never by hand.

import type * as live from "./generated/live";

export type {
  CameraMessage,
  GoalMessage,
  LiveMessage,
  PerceivedMessage,
  ReplayMessage,
  SimBox,
  TelemetryMessage as Telemetry,
  TruthMessage as Truth,
} from "./generated/live";

export type Point = [number, number];

/** The arena's walls (metres): the cart cannot leave this rectangle. */
export interface Arena {
  x_min: number;
  y_min: number;
  x_max: number;
  y_max: number;
}

export interface FloorPlanView {
  name: string;
  origin_m: Point; // the lower-left corner of cell (0, 0)
  resolution_m: number;
  width: number;
  height: number;
  cells: { free: number; occupied: number; unknown: number };
  image: string; // the PNG's URL
}

export interface MapView {
  version?: number;
  cols: number;
  rows: number;
  step_m: number;
  origin_m?: Point; // node (0, 0)
  footprint_radius_m: number;
  arena: Arena;
  obstacles: Point[];
  floor_plan?: FloorPlanView | null;
  unknown_is_free?: boolean;
}

export interface Plan {
  start?: Point;
  waypoints: Point[];
  grid_path: Point[];
  length_m: number;
  grid_length_m?: number;
}

/** The mission, as /api/status gives it and /ws "hello" and "mission" send it. */
export type MissionView = Omit<live.MissionMessage, "type">;

export interface FirmwareStatus {
  mode: string;
  flags: string[];
  waypoint_index: number;
  waypoint_count: number;
  loop_overruns: number;
  cpu_load_pct: number;
  cpu_max_pct: number;
  rx_errors: number;
  last_error: string | null;
}

export type Pose = live.Pose;

/** A restart of the controller the gateway noticed (cart2d/gateway/state.py, ResetReport). */
export type ResetReport = Omit<live.ResetMessage, "type" | "pose_trust">;

/** Whether the gateway plans from the firmware's pose; why not, in words. */
export type PoseTrust = live.PoseTrustView;

export type RoutineView = Omit<live.RoutineMessage, "type">;

export interface StatusView {
  link: { state: string; port: string; simulated: boolean; error?: string };
  firmware: { firmware: string; protocol: number; waypoint_capacity: number } | null;
  mission: MissionView;
  status?: FirmwareStatus;
  pose?: Pose;
  reset: { last: ResetReport | null; noticed: number };
  pose_trust: PoseTrust;
  routine: RoutineView;
  replay?: ReplayView; // `cart2d replay`: a recording played back, no robot behind it
}

export interface ReplayView {
  file: string;
  state: "waiting" | "playing" | "paused" | "ended";
  position_s: number;
  duration_s: number;
  speed: number;
  loop: boolean;
  sent: number;
  seeks: number; // seeks, restarts and loops so far
  version: number; // counts its changes of state: an older answer is out of date
}

export interface ProtocolCommand {
  code: number;
  name: string;
  args: string;
  results: string;
  arg_count: number | null;
}

export interface CommandReply {
  command: string;
  status: string;
  results: number[];
  message: string;
}

/** The simulated world's boxes (GET /api/sim/world; /ws "sim_world" when they change). */
export type SimWorldView = Omit<live.SimWorldMessage, "type">;

/** A failed request, with the gateway's {"detail": ...} (or what went wrong) as its message. */
export class ApiError extends Error {
  constructor(
    message: string,
    readonly status: number,
  ) {
    super(message);
    this.name = "ApiError";
  }
}

const TOKEN_KEY = "cart2d-token";

export function token(): string | null {
  try {
    return localStorage.getItem(TOKEN_KEY);
  } catch {
    return null;
  }
}

export function setToken(value: string): void {
  try {
    localStorage.setItem(TOKEN_KEY, value);
  } catch {
    /* private mode: the token lasts for this page only */
  }
}

function detailOf(body: unknown): string | null {
  if (body && typeof body === "object" && "detail" in body) {
    const detail = (body as { detail: unknown }).detail;
    if (typeof detail === "string") return detail;
    if (Array.isArray(detail)) {
      return detail
        .map((d: unknown) => (d && typeof d === "object" && "msg" in d ? String(d.msg) : String(d)))
        .join("; ");
    }
  }
  return null;
}

/** A request body sent as it is (a file's bytes), not as JSON. */
export class Raw {
  constructor(
    readonly data: Blob | string,
    readonly type: string,
  ) {}
}

export interface FirmwareSetting {
  id: number;
  name: string;
  unit: string;
  min: number;
  max: number;
  default: number;
  doc: string;
  value: number;
}

export interface UpdateJob {
  state: "idle" | "running" | "done" | "failed";
  error: string; // why it failed, without a label
  log: string[];
  elapsed_s: number;
}

export interface GatewaySettings {
  network: { host: string; port: number };
}

export async function api<T>(method: string, path: string, body?: unknown, timeoutMs = 8000): Promise<T> {
  const headers: Record<string, string> = {};
  // A change always says what it carries, with or without a body: the gateway refuses changes in
  // the types a form or a beacon from another site could send (SECURITY.md).
  if (body instanceof Raw) headers["Content-Type"] = body.type;
  else if (body !== undefined || (method !== "GET" && method !== "HEAD")) headers["Content-Type"] = "application/json";
  const t = token();
  if (t) headers["X-Cart2d-Token"] = t;
  let response: Response;
  try {
    response = await fetch(path, {
      method,
      headers,
      body: body === undefined ? null : body instanceof Raw ? body.data : JSON.stringify(body),
      signal: AbortSignal.timeout(timeoutMs),
    });
  } catch (err) {
    const timedOut = err instanceof DOMException && err.name === "TimeoutError";
    throw new ApiError(
      timedOut ? "The gateway did not answer in time." : "The gateway cannot be reached: is cart2d running?",
      0,
    );
  }
  let parsed: unknown = null;
  const text = await response.text();
  try {
    parsed = text ? JSON.parse(text) : null;
  } catch {
    parsed = null;
  }
  if (!response.ok) {
    const detail = detailOf(parsed) ?? (text.trim() || response.statusText);
    throw new ApiError(sentence(detail), response.status);
  }
  return parsed as T;
}

/** "the goal is off the map" → "The goal is off the map." */
export function sentence(text: string): string {
  const s = text.trim();
  if (!s) return "Something went wrong.";
  const first = s.charAt(0).toUpperCase() + s.slice(1);
  return /[.!?]$/.test(first) ? first : `${first}.`;
}
