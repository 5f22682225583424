// The gateway's API (cart2d/server/, GET /openapi.json): the shapes the panel reads, and one
// fetch wrapper that turns every failure into a sentence a person can act on.

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

export interface MissionView {
  state: "idle" | "driving" | "arrived" | "failed";
  goal: Point | null;
  reason: string;
  elapsed_s?: number;
  plan: Plan | null;
}

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

export interface Pose {
  x: number;
  y: number;
  theta: number;
}

/** A restart of the controller the gateway noticed (cart2d/gateway/state.py, ResetReport). */
export interface ResetReport {
  time: string; // ISO 8601, UTC
  cause: string[];
  cause_words: string;
  expected: boolean; // the gateway caused it (a soft reset, a firmware update)
  caused_by: string;
  boot_count: number;
  pose_restored: boolean;
  pose: Pose | null;
  mission_ended: boolean;
  message: string;
}

/** Whether the gateway plans from the firmware's pose; why not, in words. */
export interface PoseTrust {
  trusted: boolean;
  reason: string;
}

export interface RoutineView {
  state: "idle" | "running" | "done" | "failed";
  words: string;
}

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

/** The replay's own /ws message: its state changed; after a seek (and to a panel that opens)
 * also the cart's trails up to the position, before the state there. */
export interface ReplayMessage {
  type: "replay";
  state: ReplayView["state"];
  position_s: number;
  duration_s: number;
  seeks: number;
  version: number;
  trail?: Point[]; // odometry
  truth_trail?: Point[];
}

/** A recorded mission's goal started or ended (`cart2d mission`'s recordings). */
export interface GoalMessage {
  type: "goal";
  index: number;
  of: number;
  goal: Point;
  state: "started" | "reached" | "failed";
  reason?: string;
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

export interface Telemetry {
  type: "telemetry";
  x: number;
  y: number;
  theta: number;
  v_left: number;
  v_right: number;
  v_left_target: number;
  v_right_target: number;
  pwm_left: number;
  pwm_right: number;
  v: number;
  omega: number;
  v_target: number;
  omega_target: number;
  distance_to_waypoint: number;
  waypoint_index: number;
  mode_name: string;
  flag_names: string[];
  tick: number;
}

export interface Truth {
  type: "truth";
  t: number;
  x: number;
  y: number;
  theta: number;
  v: number;
  omega: number;
  collisions: number;
  wall_contacts?: number; // touches of a wall, and of a box the map may not know (sim/README.md)
  box_contacts?: number;
}

/** One message of /ws; each WebSocket message is an array of them, a frame (server/live.py). */
export type LiveMessage =
  | Telemetry
  | Truth
  | ({ type: "hello" } & MissionView)
  | ({ type: "mission" } & MissionView)
  | ({ type: "reset"; pose_trust: PoseTrust } & ResetReport)
  | ({ type: "pose_trust"; how: string } & PoseTrust)
  | ({ type: "routine" } & RoutineView)
  | { type: "map"; version: number; why: string }
  | PerceivedMessage
  | CameraMessage
  | SimWorldMessage
  | ReplayMessage
  | GoalMessage;

/** A box standing in the simulated world (GET /api/sim/world): centre and size, m; height, m. */
export interface SimBox {
  id: string;
  x: number;
  y: number;
  sx: number;
  sy: number;
  height: number;
  colour: string;
  solid?: boolean;
}

/** The simulated world's boxes (GET /api/sim/world; /ws "sim_world" when they change). */
export interface SimWorldView {
  version: number | null;
  boxes: SimBox[];
}

export type SimWorldMessage = { type: "sim_world" } & SimWorldView;

/** The live map's perceived layer (GET /api/perception, /ws "perceived"): [x, y, p_occupied]. */
export interface PerceivedMessage {
  type: "perceived";
  resolution: number;
  cells: [number, number, number][];
}

/** A processed camera frame (/ws "camera"): its field of view and the obstacle bases it saw, map m. */
export interface CameraMessage {
  type: "camera";
  t: number | null;
  fov: Point[];
  hits: Point[];
}

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
