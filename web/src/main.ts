// The cart2d control panel: status and health, live map, emergency stop, the generic-command
// form, manual driving, live plots and tuning, against the gateway's HTTP API and its /ws stream.

import "./style.css";
import "./messages.css";
import "./controls.css";
import {
  api,
  ApiError,
  sentence,
  token,
  type LiveMessage,
  type MapView,
  type MissionView,
  type Point,
  type StatusView,
} from "./api";
import { GatewayPanel } from "./admin";
import { CommandForm } from "./command";
import { CameraCard } from "./camera";
import { byId as $, say } from "./dom";
import { Driver } from "./drive";
import { SimFaults } from "./faults";
import { SimWorld } from "./sim_world";
import { age, count } from "./format";
import { FlagBadges, TelemetryClock } from "./health";
import { LiveMap, type MapMode, type Pose } from "./map";
import { MapMessage } from "./map_message";
import { uploadBody, uploadMap } from "./map_upload";
import { parseNumber } from "./parse";
import { LivePlots } from "./plots";
import { TelemetryRecord } from "./record";
import { ReplayBar } from "./replay";
import { RestartNotice } from "./restart";
import { StepResponse } from "./step";
import { gatewayAnswers, TokenForm, wsUrl } from "./token";
import { Toasts } from "./toasts";
import { Trajectory } from "./trajectory";
import { Tuning, type PanelContext } from "./tuning";
import { initMapSave } from "./map_save";
import { ExploreButton } from "./explore";

// -- messages ----------------------------------------------------------------------------------
const toasts = new Toasts($("messages"), [".segmented", "#cmd-form", "#estop"], document.querySelector("header") ?? document.body);
const notify = (text: string, kind: "error" | "info" = "error"): void => toasts.show(text, kind);

function errorText(err: unknown): string {
  if (err instanceof ApiError) {
    if (err.status === 401) tokenForm.show();
    return err.message;
  }
  return sentence(err instanceof Error ? err.message : String(err));
}

const ctx: PanelContext = { notify, errorText };
initMapSave(ctx);
const exploreButton = new ExploreButton(ctx);
let tokenRefused = false; // the live stream was refused for the token: wait for a new one
const tokenForm = new TokenForm(ctx, () => {
  tokenRefused = false;
  if (live) live.close();
  else connect();
});

// -- status bar and health ---------------------------------------------------------------------
const linkDot = $("link-dot");
const linkState = $("link-state");
const clock = new TelemetryClock();
const badges = new FlagBadges($("fw-flags"), $("health"), (text) => notify(text, "info"));
let gatewayUp = false;
let wsUp = false;
let lastStatus: StatusView | null = null;
let replaying = false; // `cart2d replay`: a recording, no robot: nothing here drives or changes anything

/** The replay badge; in a replay the page hides every control (controls.css, data-replay). */
function showReplay(s: StatusView): void {
  replaying = s.replay !== undefined;
  document.body.dataset["replay"] = replaying ? "on" : "off";
  const badge = $("replay-badge");
  badge.hidden = !s.replay;
  if (s.replay) {
    const r = s.replay;
    badge.textContent = `replay of ${r.file}: ${r.position_s.toFixed(1)} / ${r.duration_s.toFixed(1)} s (${r.state})`;
  }
  replayBar.show(s.replay);
}
// Keys drive and stop the cart: in a replay there is none (a capture listener runs before theirs).
window.addEventListener(
  "keydown",
  (e) => {
    const typing = e.target instanceof HTMLInputElement || e.target instanceof HTMLSelectElement;
    if (replaying && !typing) e.stopImmediatePropagation();
  },
  { capture: true },
);

/** The link indicator and the freshness of the live values: a link that is up but whose
 * telemetry has stopped (switched off, or a quiet link) shows stale values with their age. */
function renderLink(): void {
  let state: "connected" | "stale" | "reconnecting" | "lost";
  let text: string;
  const stale = clock.stale() && !replaying; // a paused replay's telemetry is as it was then, not late
  if (!gatewayUp) {
    state = "lost";
    text = "lost: the gateway does not answer";
  } else if (lastStatus?.link.state === "connected" && wsUp) {
    const a = clock.ageS();
    state = stale ? "stale" : "connected";
    text = stale ? `connected, no telemetry ${a === null ? "yet" : `for ${age(a)}`}` : "connected";
  } else if (tokenRefused) {
    state = "reconnecting";
    text = "live data needs the access token";
  } else {
    state = "reconnecting";
    text = lastStatus?.link.state === "connected" ? "live data reconnecting…" : "robot link reconnecting…";
  }
  linkDot.className = `dot dot-${state}`;
  linkState.textContent = text;
  linkState.title = lastStatus?.link.state === "reconnecting" ? (lastStatus.link.error ?? "") : "";
  document.body.dataset["link"] = state === "stale" ? "connected" : state;
  document.body.dataset["telemetry"] = stale ? "stale" : "live";
  const ageText = clock.words();
  $("telemetry-age").textContent = ageText;
  for (const el of document.querySelectorAll<HTMLElement>(".live-value")) {
    el.classList.toggle("stale", stale);
    el.title = stale ? `Telemetry ${ageText}: this value is not current.` : "";
  }
  $("link-port").textContent = lastStatus ? (lastStatus.link.simulated ? "simulator" : lastStatus.link.port) : "";
}
window.setInterval(renderLink, 500);

// The toast pollStatus showed (the link's error, the gateway not answering): taken away as soon as it
// is no longer true, so that no stale "sim-tty is not open yet" stays beside a connected link.
let statusProblem = "";
let gatewayDown = false;
function showStatusProblem(text: string): void {
  if (text === statusProblem) return;
  if (statusProblem) toasts.dismiss(statusProblem);
  if (text) notify(text);
  statusProblem = text;
}

async function pollStatus(): Promise<void> {
  try {
    const s = await api<StatusView>("GET", "/api/status", undefined, 4000);
    gatewayUp = true;
    lastStatus = s;
    showReplay(s);
    $("fw-version").textContent = s.firmware ? `${s.firmware.firmware} (protocol ${s.firmware.protocol})` : "–";
    if (s.status) {
      $("fw-mode").textContent = s.status.mode;
      $("cpu-load").textContent = `${s.status.cpu_load_pct} % (max ${s.status.cpu_max_pct} %)`;
      const over = $("overruns");
      over.textContent = String(s.status.loop_overruns);
      over.classList.toggle("bad", s.status.loop_overruns > 0);
      if (clock.stale()) badges.show(s.status.flags); // else the telemetry's, fresher
    }
    renderMission(s.mission, false);
    restartNotice.update(s);
    gatewayDown = false;
    showStatusProblem(s.link.error ? sentence(`The robot does not answer: ${s.link.error}`) : "");
  } catch (err) {
    if (!gatewayDown) showStatusProblem(errorText(err));
    gatewayDown = true;
    gatewayUp = false;
  }
  renderLink();
}

// -- map and mission ---------------------------------------------------------------------------
const canvas = $<HTMLCanvasElement>("map");
const liveMap = new LiveMap(
  canvas,
  { click: (world, node) => void mapClick(world, node), setPose: (p) => void setPoseFromMap(p) },
  $("map-cursor"),
);
new CameraCard(ctx, liveMap);
const simWorld = new SimWorld(ctx, liveMap);
let mapMode: MapMode = liveMap.mode; // "Go here": a first click sends the cart, it adds no obstacle
let missionState = "";
const MAP_HINTS: Record<MapMode, string> = {
  obstacle: "Click a node to add or remove an obstacle. Wheel or pinch to zoom, drag to pan.",
  goto: "Click a point to send the robot there (planned around the obstacles).",
  pose: "Press where the cart is and drag the way it faces, then release: that sets its pose.",
  box: "Click to drop a 0.2 × 0.2 m box in the simulated world; click a box to take it away.",
};
const MAP_MODES: readonly MapMode[] = ["obstacle", "goto", "pose", "box"];

for (const radio of document.querySelectorAll<HTMLInputElement>('input[name="map-mode"]')) {
  radio.addEventListener("change", () => {
    if (!radio.checked) return;
    mapMode = MAP_MODES.find((m) => m === radio.value) ?? "goto";
    liveMap.mode = mapMode;
    canvas.dataset["mode"] = mapMode;
    $("map-hint").textContent = MAP_HINTS[mapMode];
  });
}
canvas.dataset["mode"] = mapMode;
$("map-hint").textContent = MAP_HINTS[mapMode];
$("map-zoom-in").addEventListener("click", () => liveMap.zoomIn());
$("map-zoom-out").addEventListener("click", () => liveMap.zoomOut());
$("map-fit").addEventListener("click", () => liveMap.fit());

async function setPoseFromMap(p: Pose): Promise<void> {
  if (replaying) return;
  try {
    await api("POST", "/api/pose", { x: round3(p.x), y: round3(p.y), theta: round3(p.theta) });
    liveMap.hidePlan(); // planned from the pose before
    liveMap.clearTrails();
    notify(`Pose set to (${p.x.toFixed(2)}, ${p.y.toFixed(2)}), facing ${((p.theta * 180) / Math.PI).toFixed(0)}°.`, "info");
  } catch (err) {
    notify(errorText(err));
  }
}

const round3 = (v: number): number => Math.round(v * 1000) / 1000;

const mapFile = $<HTMLInputElement>("map-file");
mapFile.addEventListener("change", () => void loadFloorPlan());
async function loadFloorPlan(): Promise<void> {
  const files = [...(mapFile.files ?? [])];
  mapFile.value = "";
  if (!files.length) return;
  const body = await uploadBody(files, $<HTMLInputElement>("map-resolution").value, $<HTMLInputElement>("map-origin").value);
  if (typeof body === "string") {
    notify(body);
    return;
  }
  try {
    const view = await uploadMap(body);
    liveMap.setMap(view);
    liveMap.fit();
    const plan = view.floor_plan;
    notify(plan ? `Loaded ${plan.name}: ${plan.width} × ${plan.height} cells of ${plan.resolution_m} m.` : "Map loaded.", "info");
    if (view.pose_warning) notify(view.pose_warning); // the cart off the plan's floor: what to do
  } catch (err) {
    notify(errorText(err));
  }
}

async function loadMap(): Promise<void> {
  try {
    liveMap.setMap(await api<MapView>("GET", "/api/map"));
  } catch (err) {
    notify(errorText(err));
  }
}

async function mapClick(world: Point, node: Point | null): Promise<void> {
  if (replaying) return;
  if (mapMode === "goto") {
    await goTo(Math.round(world[0] * 1000) / 1000, Math.round(world[1] * 1000) / 1000, liveMap.toScreen(world[0], world[1]));
    return;
  }
  if (mapMode === "box") {
    await simWorld.click(world);
    return;
  }
  if (!node) {
    notify("Click on a node of the grid to add or remove an obstacle.", "info");
    return;
  }
  const present = !liveMap.hasObstacle(node);
  try {
    liveMap.setMap(await api<MapView>("PUT", "/api/map/obstacle", { x: node[0], y: node[1], present }));
  } catch (err) {
    notify(errorText(err));
  }
}

// A go-to's answer is said once, where it was asked: in the form's line under the map, or for a
// click in "Go here" mode on the map beside the point clicked (the line under the map may be below
// the fold).
const gotoMsg = $<HTMLOutputElement>("goto-msg");
const mapMsg = new MapMessage($<HTMLOutputElement>("map-msg"));
async function goTo(x: number, y: number, clicked?: Point): Promise<void> {
  const answer = (text: string, error = false): void => {
    if (clicked) mapMsg.say(text, clicked, error);
    else say(gotoMsg, text, error);
  };
  if (clicked) say(gotoMsg, "");
  answer(`Planning to (${x.toFixed(2)}, ${y.toFixed(2)})…`);
  try {
    const plan = await api<{ length_m: number; waypoints: Point[] }>("POST", "/api/goto", { x, y });
    answer(`Driving to (${x.toFixed(2)}, ${y.toFixed(2)}): ${plan.length_m.toFixed(2)} m, ${count(plan.waypoints.length, "waypoint")}.`);
  } catch (err) {
    answer(errorText(err), true);
  }
}

const gotoForm = $<HTMLFormElement>("goto-form");
gotoForm.addEventListener("submit", (e) => {
  e.preventDefault();
  const field = (name: string): string => (gotoForm.elements.namedItem(name) as HTMLInputElement).value;
  const x = parseNumber(field("x"), "x");
  const y = parseNumber(field("y"), "y");
  if (!x.ok || !y.ok) {
    say(gotoMsg, !x.ok ? x.message : !y.ok ? y.message : "", true);
    return;
  }
  void goTo(x.value, y.value);
});

function renderMission(m: MissionView, fromStream: boolean): void {
  liveMap.setPlan(m.plan, m.goal);
  liveMap.driving = m.state === "driving";
  $("mission-state").textContent = m.state;
  document.body.dataset["mission"] = m.state;
  const at = m.goal ? `(${m.goal[0].toFixed(2)}, ${m.goal[1].toFixed(2)})` : "";
  const length = m.plan ? `, ${m.plan.length_m.toFixed(2)} m planned` : "";
  const words: Record<MissionView["state"], string> = {
    idle: "idle",
    driving: `driving to ${at}`,
    arrived: `arrived at ${at}`,
    failed: `failed on the way to ${at}`,
  };
  $("mission-detail").textContent =
    m.state === "idle" ? "idle" : `${words[m.state]}${length}${m.reason ? `: ${m.reason}` : ""}`;
  if (fromStream && m.state !== missionState) {
    if (m.state === "failed" && m.reason) notify(sentence(`The mission failed: ${m.reason}`));
    if (m.state === "arrived") notify(`Arrived at ${at}.`, "info");
  }
  missionState = m.state;
}

// -- panels ------------------------------------------------------------------------------------
const record = new TelemetryRecord();
const trajectory = new Trajectory($("plot-xy"), $("plot-xy-note"));
const plotsCard = $("plots");
const plots = new LivePlots(
  record,
  { wheels: $("plot-wheels"), body: $("plot-body"), pwm: $("plot-pwm"), distance: $("plot-distance") },
  trajectory,
  plotsCard,
);
const tuning = new Tuning($("tuning"), ctx);
const step = new StepResponse($("tuning"), ctx, clock);
const commandForm = new CommandForm(ctx, () => tuning.names());
tuning.onLoad = () => commandForm.settingsLoaded();
commandForm.onAccepted = showRawPath;
const driver = new Driver(ctx, () => ({ vMax: tuning.value("v_max_mps") ?? 0.5, wMax: tuning.value("w_max_radps") ?? Math.PI }));
const gatewayPanel = new GatewayPanel(ctx);
const simFaults = new SimFaults(ctx);
const restartNotice = new RestartNotice(ctx);
const replayBar = new ReplayBar(ctx, liveMap, record);
window.addEventListener("cart2d-settings-imported", () => void loadMap());

// -- live stream -------------------------------------------------------------------------------
let live: WebSocket | null = null;
let retryMs = 500;
const fmt = (v: number, unit: string, digits = 3): string => `${v.toFixed(digits)} ${unit}`;
const deg = (rad: number): number => (rad * 180) / Math.PI;

function setReadout(id: string, label: string, value: number, text: string): void {
  const el = $(id);
  el.dataset["value"] = value.toFixed(4);
  el.textContent = `${label} ${text}`;
}

function onMessage(msg: LiveMessage): void {
  switch (msg.type) {
    case "telemetry":
      clock.frame(msg.tick);
      liveMap.waypointIndex = missionState === "driving" ? msg.waypoint_index : -1;
      liveMap.setPose({ x: msg.x, y: msg.y, theta: msg.theta });
      setReadout("pose-x", "x", msg.x, fmt(msg.x, "m"));
      setReadout("pose-y", "y", msg.y, fmt(msg.y, "m"));
      setReadout("pose-theta", "θ", msg.theta, `${deg(msg.theta).toFixed(1)}°`);
      $("fw-mode").textContent = msg.mode_name;
      badges.show(msg.flag_names);
      record.add(msg);
      step.onTelemetry(msg);
      break;
    case "truth": {
      liveMap.setTruth({ x: msg.x, y: msg.y, theta: msg.theta });
      record.addTruth(msg);
      step.onContacts(msg.collisions + (msg.wall_contacts ?? 0) + (msg.box_contacts ?? 0));
      const row = $("truth-row");
      row.hidden = false;
      const p = liveMap.pose;
      const drift = p ? ` (odometry off by ${(Math.hypot(p.x - msg.x, p.y - msg.y) * 1000).toFixed(0)} mm)` : "";
      $("truth-pose").textContent =
        `x ${fmt(msg.x, "m")} y ${fmt(msg.y, "m")} θ ${deg(msg.theta).toFixed(1)}°${drift}` +
        (msg.collisions ? `, ${count(msg.collisions, "collision")}` : "");
      break;
    }
    case "hello":
    case "mission":
      renderMission(msg, msg.type === "mission");
      break;
    case "reset":
      restartNotice.onReset(msg, msg.pose_trust);
      liveMap.hidePlan(); // the plan's pose is gone
      break;
    case "map":
      if (msg.version !== liveMap.map?.version) void loadMap();
      break;
    case "pose_trust":
      restartNotice.onPoseTrust(msg, msg.how);
      break;
    case "routine":
      restartNotice.onRoutine(msg);
      break;
    case "perceived":
      liveMap.setPerceived(msg.resolution, msg.cells);
      break;
    case "camera":
      liveMap.setCamera(msg.fov, msg.hits);
      break;
    case "localisation":
      liveMap.setLocalisation(msg);
      break;
    case "sim_world":
      simWorld.show(msg);
      break;
    case "exploration":
      exploreButton.show(msg);
      break;
    case "replay":
    case "goal":
      replayBar.onMessage(msg);
      break;
  }
}

function connect(): void {
  const ws = new WebSocket(wsUrl(token()));
  live = ws;
  let opened = false;
  ws.addEventListener("open", () => {
    opened = true;
    wsUp = true;
    retryMs = 500;
    renderLink();
  });
  ws.addEventListener("message", (e) => {
    // Each WebSocket message is a frame: an array of live messages, oldest first (server/live.py).
    let frame: LiveMessage[];
    try {
      frame = JSON.parse(String(e.data)) as LiveMessage[];
    } catch (err) {
      console.warn("unreadable live frame", err);
      return;
    }
    for (const msg of frame) {
      try {
        onMessage(msg);
      } catch (err) {
        console.warn("unreadable live message", err);
      }
    }
  });
  ws.addEventListener("close", (e) => void closed(e, opened));
}

async function closed(e: CloseEvent, opened: boolean): Promise<void> {
  wsUp = false;
  live = null;
  renderLink();
  // The gateway refuses a WebSocket without its token before accepting it, which reaches the page
  // as a failed handshake (1006, no reason); 1008 with a reason if it closes one it accepted.
  const forToken =
    (e.code === 1008 && e.reason.includes("token")) || (!opened && e.code !== 1008 && (await gatewayAnswers()));
  if ((e.code === 1008 || forToken) && !tokenRefused) {
    notify(sentence(forToken ? "The live data needs this gateway's access token" : e.reason || "The gateway refused the live stream"));
    if (forToken) tokenForm.show();
  }
  tokenRefused = forToken;
  renderLink();
  if (forToken) return; // the same token would be refused again: connect() when a new one is entered
  window.setTimeout(connect, retryMs);
  retryMs = Math.min(retryMs * 2, 5000);
}

// -- emergency stop ----------------------------------------------------------------------------
async function emergencyStop(): Promise<void> {
  driver.releaseAll();
  step.cancel();
  try {
    await api("POST", "/api/stop", undefined, 3000);
    notify("Stopped: motors off.", "info");
  } catch (err) {
    notify(`The stop did not get through: ${errorText(err)}`);
  }
}
$("estop").addEventListener("click", () => void emergencyStop());
window.addEventListener("keydown", (e) => {
  if (e.key !== "Escape") return;
  e.preventDefault();
  void emergencyStop();
});

/** A path sent past the planner (GOTO, WAIT_XY_ARRAY from this form) is drawn, with a warning. */
function showRawPath(name: string, args: number[]): void {
  let points: Point[] = [];
  if (name === "GOTO" && args.length >= 2) points = [[args[0] ?? 0, args[1] ?? 0]];
  if (name === "WAIT_XY_ARRAY") {
    for (let k = 1; k + 1 < args.length; k += 2) points.push([args[k] ?? 0, args[k + 1] ?? 0]);
  }
  if (name === "SET_POSE" || name === "RESET") liveMap.hidePlan();
  if (!points.length) return;
  liveMap.setRawPath(points);
  const warning = $("map-warning");
  warning.hidden = false;
  warning.textContent = `The path sent with ${name} bypasses the planner: nothing checks it against the obstacles or the walls.`;
  notify(warning.textContent, "info");
}

// -- plots -------------------------------------------------------------------------------------
const pause = $<HTMLButtonElement>("plot-pause");
plots.onHold = (held) => {
  pause.setAttribute("aria-pressed", String(held));
  pause.textContent = held ? "Resume" : "Pause";
};
pause.addEventListener("click", () => plots.hold(!plots.holding));
$("plot-zoom-in").addEventListener("click", () => plots.zoom(0.5));
$("plot-zoom-out").addEventListener("click", () => plots.zoom(2));
const windowSelect = $<HTMLSelectElement>("plot-window");
windowSelect.addEventListener("change", () => plots.setWindow(Number(windowSelect.value)));
$("plot-csv").addEventListener("click", () => {
  const text = plots.csv();
  if (!text) {
    notify("Nothing recorded yet: the plots record the robot's telemetry while the page is open.", "info");
    return;
  }
  const a = document.createElement("a");
  a.href = URL.createObjectURL(new Blob([text], { type: "text/csv" }));
  a.download = `cart2d-telemetry-${new Date().toISOString().replace(/[:.]/g, "-")}.csv`;
  a.click();
  window.setTimeout(() => URL.revokeObjectURL(a.href), 1000);
});
$("clear-trail").addEventListener("click", () => liveMap.clearTrails());
$("clear-obstacles").addEventListener("click", () => void clearObstacles());

/** Every obstacle of the user's off the map, once confirmed (DELETE /api/map/obstacles). */
async function clearObstacles(): Promise<void> {
  if (replaying) return;
  const n = liveMap.map?.obstacles.length ?? 0;
  if (n === 0) {
    notify("There are no obstacles to clear.", "info");
    return;
  }
  const what = n === 1 ? "the obstacle" : `all ${n} obstacles`;
  if (!window.confirm(`Remove ${what} from the map? The floor plan's walls stay.`)) return;
  try {
    const answer = await api<{ removed: Point[]; version: number }>("DELETE", "/api/map/obstacles");
    await loadMap();
    notify(`Removed ${count(answer.removed.length, "obstacle")}.`, "info");
  } catch (err) {
    notify(errorText(err));
  }
}

// -- start -------------------------------------------------------------------------------------
renderLink();
void loadMap();
void commandForm.load();
void tuning.load();
void gatewayPanel.load();
void simFaults.load();
void simWorld.load();
void pollStatus();
window.setInterval(() => void pollStatus(), 1000);
connect();
