// The cart2d control panel: status, live map, emergency stop, the generic-command form, manual
// driving and live plots, against the gateway's HTTP API and its /ws stream.

import "./style.css";
import {
  api,
  ApiError,
  sentence,
  setToken,
  token,
  type CommandReply,
  type LiveMessage,
  type MapView,
  type MissionView,
  type Point,
  type ProtocolCommand,
  type StatusView,
} from "./api";
import { Joystick, type Stick } from "./joystick";
import { LiveMap, type MapMode, type Pose } from "./map";
import { uploadBody, uploadMap } from "./map_upload";
import { parseNumber } from "./parse";
import { GatewayPanel } from "./admin";
import { byId as $, say } from "./dom";
import { LivePlots } from "./plots";
import { RestartNotice } from "./restart";
import { StepResponse, Tuning, type PanelContext } from "./tuning";

// -- messages ----------------------------------------------------------------------------------
const messages = $("messages");

function notify(text: string, kind: "error" | "info" = "error", ttlMs = kind === "error" ? 12000 : 4000): void {
  for (const old of messages.querySelectorAll<HTMLElement>(".msg")) {
    if (old.dataset["text"] === text) old.remove(); // the same sentence once, freshest last
  }
  const item = document.createElement("div");
  item.className = `msg msg-${kind}`;
  item.dataset["text"] = text;
  const span = document.createElement("span");
  span.textContent = text;
  const close = document.createElement("button");
  close.type = "button";
  close.className = "msg-close";
  close.setAttribute("aria-label", "dismiss");
  close.textContent = "×";
  close.addEventListener("click", () => item.remove());
  item.append(span, close);
  messages.append(item);
  while (messages.children.length > 4) messages.firstElementChild?.remove();
  window.setTimeout(() => item.remove(), ttlMs);
}

function errorText(err: unknown): string {
  if (err instanceof ApiError) {
    if (err.status === 401) showTokenForm();
    return err.message;
  }
  return sentence(err instanceof Error ? err.message : String(err));
}

// -- access token (a gateway bound off loopback) -----------------------------------------------
const tokenForm = $<HTMLFormElement>("token-form");
const tokenMsg = $<HTMLOutputElement>("token-msg");
let tokenRefused = false; // the live stream was refused for the token: wait for a new one
function showTokenForm(): void {
  tokenForm.hidden = false;
}

/** The URL of the gateway's live stream, with `accessToken` if there is one. */
function wsUrl(accessToken: string | null): string {
  const proto = location.protocol === "https:" ? "wss:" : "ws:";
  return `${proto}//${location.host}/ws${accessToken ? `?token=${encodeURIComponent(accessToken)}` : ""}`;
}

/** Whether the gateway takes `value`: a WebSocket with it opens. The gateway refuses one before
 * accepting it, which a browser sees as a failed handshake (403, close code 1006), not as 1008. */
function checkToken(value: string): Promise<"ok" | "refused" | "unreachable"> {
  return new Promise((done) => {
    const ws = new WebSocket(wsUrl(value));
    const timer = window.setTimeout(() => {
      done("unreachable");
      ws.close();
    }, 5000);
    ws.addEventListener("open", () => {
      window.clearTimeout(timer);
      done("ok");
      ws.close();
    });
    ws.addEventListener("close", () => {
      window.clearTimeout(timer);
      void gatewayAnswers().then((up) => done(up ? "refused" : "unreachable"));
    });
  });
}

tokenForm.addEventListener("submit", (e) => {
  e.preventDefault();
  const input = tokenForm.elements.namedItem("token") as HTMLInputElement;
  const value = input.value.trim();
  if (value.length < 16) {
    say(tokenMsg, "The access token is at least 16 characters: copy it from the gateway's terminal.", true);
    return;
  }
  say(tokenMsg, "Checking the token…");
  void checkToken(value).then((verdict) => {
    if (verdict === "refused") {
      input.value = "";
      say(tokenMsg, "That is not this gateway's access token: copy it from the terminal where cart2d runs.", true);
      return;
    }
    if (verdict === "unreachable") {
      say(tokenMsg, "The gateway cannot be reached to check the token: try again.", true);
      return;
    }
    setToken(value);
    input.value = "";
    say(tokenMsg, "");
    tokenForm.hidden = true;
    notify("Token accepted and saved in this browser: changes are allowed now.", "info");
    tokenRefused = false;
    if (live) live.close();
    else connect();
  });
});
$("token-later").addEventListener("click", () => {
  tokenForm.hidden = true;
  say(tokenMsg, "");
});

// -- status bar --------------------------------------------------------------------------------
const linkDot = $("link-dot");
const linkState = $("link-state");
let gatewayUp = false;
let wsUp = false;
let lastStatus: StatusView | null = null;

function renderLink(): void {
  let state: "connected" | "reconnecting" | "lost";
  let text: string;
  if (!gatewayUp) {
    state = "lost";
    text = "lost: the gateway does not answer";
  } else if (lastStatus?.link.state === "connected" && wsUp) {
    state = "connected";
    text = "connected";
  } else if (tokenRefused) {
    state = "reconnecting";
    text = "live data needs the access token";
  } else {
    state = "reconnecting";
    text = lastStatus?.link.state === "connected" ? "live data reconnecting…" : "robot link reconnecting…";
  }
  linkDot.className = `dot dot-${state}`;
  linkState.textContent = text;
  document.body.dataset["link"] = state;
  const port = lastStatus
    ? lastStatus.link.simulated
      ? "simulator"
      : lastStatus.link.port
    : "";
  $("link-port").textContent = port;
}

let statusErrorShown = "";
async function pollStatus(): Promise<void> {
  try {
    const s = await api<StatusView>("GET", "/api/status", undefined, 4000);
    gatewayUp = true;
    lastStatus = s;
    $("fw-version").textContent = s.firmware ? `${s.firmware.firmware} (protocol ${s.firmware.protocol})` : "–";
    if (s.status) {
      $("fw-mode").textContent = s.status.mode;
      $("cpu-load").textContent = `${s.status.cpu_load_pct} % (max ${s.status.cpu_max_pct} %)`;
      const over = $("overruns");
      over.textContent = String(s.status.loop_overruns);
      over.classList.toggle("bad", s.status.loop_overruns > 0);
    }
    renderMission(s.mission, false);
    restartNotice.update(s);
    const linkError = s.link.error ? `The robot does not answer: ${s.link.error}` : "";
    if (linkError && linkError !== statusErrorShown) notify(sentence(linkError));
    statusErrorShown = linkError;
  } catch (err) {
    if (gatewayUp || statusErrorShown !== "down") notify(errorText(err));
    statusErrorShown = "down";
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
let mapMode: MapMode = "obstacle";
let missionState = "";
const MAP_HINTS: Record<MapMode, string> = {
  obstacle: "Click a node to add or remove an obstacle. Wheel or pinch to zoom, drag to pan.",
  goto: "Click a point to send the robot there (planned around the obstacles).",
  pose: "Press where the cart is and drag the way it faces, then release: that sets its pose.",
};

for (const radio of document.querySelectorAll<HTMLInputElement>('input[name="map-mode"]')) {
  radio.addEventListener("change", () => {
    if (!radio.checked) return;
    mapMode = radio.value === "goto" || radio.value === "pose" ? radio.value : "obstacle";
    liveMap.mode = mapMode;
    canvas.dataset["mode"] = mapMode;
    $("map-hint").textContent = MAP_HINTS[mapMode];
  });
}
canvas.dataset["mode"] = mapMode;
$("map-zoom-in").addEventListener("click", () => liveMap.zoomIn());
$("map-zoom-out").addEventListener("click", () => liveMap.zoomOut());
$("map-fit").addEventListener("click", () => liveMap.fit());

async function setPoseFromMap(p: Pose): Promise<void> {
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
  const body = await uploadBody(files, $<HTMLInputElement>("map-resolution").value);
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
  if (mapMode === "goto") {
    await goTo(Math.round(world[0] * 1000) / 1000, Math.round(world[1] * 1000) / 1000);
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

const gotoMsg = $<HTMLOutputElement>("goto-msg");
async function goTo(x: number, y: number): Promise<void> {
  say(gotoMsg, `Planning to (${x.toFixed(2)}, ${y.toFixed(2)})…`);
  try {
    const plan = await api<{ length_m: number; waypoints: Point[] }>("POST", "/api/goto", { x, y });
    gotoMsg.textContent = `Driving to (${x.toFixed(2)}, ${y.toFixed(2)}): ${plan.length_m.toFixed(2)} m, ${plan.waypoints.length} waypoint${plan.waypoints.length === 1 ? "" : "s"}.`;
  } catch (err) {
    const text = errorText(err);
    say(gotoMsg, text, true);
    notify(text);
  }
}

const gotoForm = $<HTMLFormElement>("goto-form");
gotoForm.addEventListener("submit", (e) => {
  e.preventDefault();
  const field = (name: string): string => (gotoForm.elements.namedItem(name) as HTMLInputElement).value;
  const x = parseNumber(field("x"), "x");
  const y = parseNumber(field("y"), "y");
  const bad = [x, y].find((p) => !p.ok);
  if (bad && !bad.ok) {
    say(gotoMsg, bad.message, true);
    return;
  }
  if (x.ok && y.ok) void goTo(x.value, y.value);
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

// -- live stream -------------------------------------------------------------------------------
const plots = new LivePlots($("plot-wheels"), $("plot-body"), $("plot-pwm"), $("plot-distance"));
const ctx: PanelContext = { notify, errorText };
const tuning = new Tuning($("tuning"), ctx);
const step = new StepResponse($("tuning"), ctx);
const gatewayPanel = new GatewayPanel(ctx);
const restartNotice = new RestartNotice(ctx);
window.addEventListener("cart2d-settings-imported", () => void loadMap());
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
      liveMap.waypointIndex = missionState === "driving" ? msg.waypoint_index : -1;
      liveMap.setPose({ x: msg.x, y: msg.y, theta: msg.theta });
      setReadout("pose-x", "x", msg.x, fmt(msg.x, "m"));
      setReadout("pose-y", "y", msg.y, fmt(msg.y, "m"));
      setReadout("pose-theta", "θ", msg.theta, `${deg(msg.theta).toFixed(1)}°`);
      $("fw-mode").textContent = msg.mode_name;
      plots.add(msg);
      step.onTelemetry(msg);
      break;
    case "truth": {
      liveMap.setTruth({ x: msg.x, y: msg.y, theta: msg.theta });
      const row = $("truth-row");
      row.hidden = false;
      const p = liveMap.pose;
      const drift = p ? ` (odometry off by ${(Math.hypot(p.x - msg.x, p.y - msg.y) * 1000).toFixed(0)} mm)` : "";
      $("truth-pose").textContent =
        `x ${fmt(msg.x, "m")} y ${fmt(msg.y, "m")} θ ${deg(msg.theta).toFixed(1)}°${drift}` +
        (msg.collisions ? `, ${msg.collisions} collision${msg.collisions > 1 ? "s" : ""}` : "");
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
    try {
      onMessage(JSON.parse(String(e.data)) as LiveMessage);
    } catch (err) {
      console.warn("unreadable live message", err);
    }
  });
  ws.addEventListener("close", (e) => void closed(e, opened));
}

/** Whether the gateway answers HTTP now (then a refused WebSocket handshake was about the token). */
async function gatewayAnswers(): Promise<boolean> {
  try {
    await api("GET", "/api/status", undefined, 3000);
    return true;
  } catch {
    return false;
  }
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
    if (forToken) showTokenForm();
  }
  tokenRefused = forToken;
  renderLink();
  if (forToken) return; // the same token would be refused again: connect() when a new one is entered
  window.setTimeout(connect, retryMs);
  retryMs = Math.min(retryMs * 2, 5000);
}

// -- emergency stop ----------------------------------------------------------------------------
async function emergencyStop(): Promise<void> {
  held.clear();
  joystick.release();
  step.cancel();
  try {
    await api("POST", "/api/stop", undefined, 3000);
    notify("Stopped: motors off.", "info");
  } catch (err) {
    notify(`The stop did not get through: ${errorText(err)}`);
  }
}
$("estop").addEventListener("click", () => void emergencyStop());

// -- manual driving ----------------------------------------------------------------------------
type Dir = "fwd" | "back" | "left" | "right";
const KEYS: Record<string, Dir> = {
  ArrowUp: "fwd",
  KeyW: "fwd",
  ArrowDown: "back",
  KeyS: "back",
  ArrowLeft: "left",
  KeyA: "left",
  ArrowRight: "right",
  KeyD: "right",
};
const held = new Set<Dir>();
const speedInput = $<HTMLInputElement>("drive-speed");
let driveTimer: number | null = null;
let driveInFlight = false;
let pendingDrive: [number, number] | null = null; // the latest command asked for while one was in flight
let stick: Stick = null;

speedInput.addEventListener("input", () => {
  $("drive-speed-out").textContent = `${Number(speedInput.value).toFixed(2)} m/s`;
});

async function sendDrive(v: number, omega: number): Promise<void> {
  if (driveInFlight) {
    pendingDrive = [v, omega]; // sent when the one in flight is answered: the final stop is never lost
    return;
  }
  driveInFlight = true;
  try {
    await api("POST", "/api/drive", { v, omega }, 2000);
  } catch (err) {
    held.clear();
    joystick.release();
    notify(errorText(err));
    if (pendingDrive && (pendingDrive[0] !== 0 || pendingDrive[1] !== 0)) pendingDrive = null;
  } finally {
    driveInFlight = false;
  }
  const next = pendingDrive;
  pendingDrive = null;
  if (next) await sendDrive(next[0], next[1]);
}

/** The firmware's max speeds (the tuning table, else its defaults) scaled by the speed slider. */
function stickLimits(): { v: number; omega: number } {
  const vMax = tuning.value("v_max_mps") ?? 0.5;
  const wMax = tuning.value("w_max_radps") ?? Math.PI;
  const fraction = Math.min(1, Number(speedInput.value) / vMax);
  return { v: vMax * fraction, omega: wMax * fraction };
}

function driveTick(): void {
  if (held.size === 0 && stick === null) {
    if (driveTimer !== null) window.clearInterval(driveTimer);
    driveTimer = null;
    void sendDrive(0, 0);
    return;
  }
  if (stick) {
    const limits = stickLimits();
    const round = (x: number): number => Math.round(x * 1000) / 1000;
    void sendDrive(round(stick.y * limits.v), round(-stick.x * limits.omega));
    return;
  }
  const speed = Number(speedInput.value);
  const v = speed * ((held.has("fwd") ? 1 : 0) - (held.has("back") ? 1 : 0));
  const omega = Math.min(3, speed * 8) * ((held.has("left") ? 1 : 0) - (held.has("right") ? 1 : 0));
  void sendDrive(v, omega);
}

function startDriving(): void {
  if (driveTimer === null) {
    driveTick();
    driveTimer = window.setInterval(driveTick, 150);
  }
}

function press(dir: Dir): void {
  held.add(dir);
  startDriving();
}

const joystick = new Joystick($("joystick"), $("joystick-knob"), (s) => {
  const first = stick === null && s !== null;
  stick = s;
  if (first) startDriving(); // then every 150 ms while held; the tick after release stops
});

function release(dir: Dir): void {
  held.delete(dir);
}

function typing(target: EventTarget | null): boolean {
  return (
    target instanceof HTMLInputElement ||
    target instanceof HTMLSelectElement ||
    target instanceof HTMLTextAreaElement
  ) && !(target instanceof HTMLInputElement && (target.type === "radio" || target.type === "range"));
}

window.addEventListener("keydown", (e) => {
  if (e.key === "Escape") {
    e.preventDefault();
    void emergencyStop();
    return;
  }
  const dir = KEYS[e.code];
  if (!dir || e.ctrlKey || e.altKey || e.metaKey || typing(e.target)) return;
  e.preventDefault();
  if (!e.repeat) press(dir);
});
window.addEventListener("keyup", (e) => {
  const dir = KEYS[e.code];
  if (dir) release(dir);
});
window.addEventListener("blur", () => {
  held.clear();
  joystick.release();
});

for (const button of document.querySelectorAll<HTMLButtonElement>("[data-drive]")) {
  const dir = button.dataset["drive"] as Dir;
  button.addEventListener("pointerdown", (e) => {
    button.setPointerCapture(e.pointerId);
    press(dir);
  });
  for (const end of ["pointerup", "pointercancel", "lostpointercapture"] as const) {
    button.addEventListener(end, () => release(dir));
  }
  button.addEventListener("contextmenu", (e) => e.preventDefault());
}

// -- generic command ---------------------------------------------------------------------------
const cmdForm = $<HTMLFormElement>("cmd-form");
const cmdSelect = $<HTMLSelectElement>("cmd-name");
const cmdMsg = $<HTMLOutputElement>("cmd-msg");
const argInputs = [0, 1, 2, 3].map((k) => cmdForm.elements.namedItem(`a${k}`) as HTMLInputElement);
let commands: ProtocolCommand[] = [];

function selected(): ProtocolCommand | undefined {
  return commands.find((c) => c.name === cmdSelect.value);
}

function names(list: string): string[] {
  return list === "–" || list.trim() === "" ? [] : list.split(",").map((s) => s.trim());
}

function describeCommand(): void {
  const c = selected();
  if (!c) return;
  const argNames = names(c.args).filter((n) => n !== "…");
  argInputs.forEach((input, k) => {
    const used = c.arg_count === null ? true : k < c.arg_count;
    input.disabled = !used;
    input.placeholder = used ? (argNames[k] ?? (c.arg_count === null ? "…" : "")) : "";
    if (!used) input.value = "";
  });
  $("cmd-args-hint").textContent =
    `arguments: ${c.args === "–" ? "none" : c.args}${c.arg_count === null ? " (up to 4 here)" : ""}; ` +
    `results: ${c.results === "–" ? "none" : c.results}`;
  cmdMsg.textContent = "";
}

async function loadProtocol(): Promise<void> {
  try {
    commands = await api<ProtocolCommand[]>("GET", "/api/protocol");
  } catch (err) {
    notify(errorText(err));
    return;
  }
  cmdSelect.replaceChildren(
    ...commands.map((c) => {
      const o = document.createElement("option");
      o.value = c.name;
      o.textContent = c.name;
      return o;
    }),
  );
  if (commands.some((c) => c.name === "POSE")) cmdSelect.value = "POSE";
  describeCommand();
}
cmdSelect.addEventListener("change", describeCommand);

/** The arguments typed, or a sentence saying why they cannot be sent. */
function commandArgs(c: ProtocolCommand): { args: number[] } | { error: string } {
  const texts = argInputs.map((i) => (i.disabled ? "" : i.value.trim()));
  const wanted = c.arg_count ?? texts.reduce((n, t, k) => (t !== "" ? k + 1 : n), 0);
  const args: number[] = [];
  for (let k = 0; k < wanted; k++) {
    const what = `argument ${k + 1}${names(c.args)[k] && names(c.args)[k] !== "…" ? ` (${names(c.args)[k]})` : ""}`;
    const p = parseNumber(texts[k] ?? "", what.charAt(0).toUpperCase() + what.slice(1));
    if (!p.ok) return { error: `${c.name} needs ${wanted} argument${wanted === 1 ? "" : "s"}: ${p.message}` };
    args.push(p.value);
  }
  return { args };
}

cmdForm.addEventListener("submit", (e) => {
  e.preventDefault();
  const c = selected();
  if (!c) {
    say(cmdMsg, "Pick a command first.", true);
    return;
  }
  const parsed = commandArgs(c);
  if ("error" in parsed) {
    say(cmdMsg, parsed.error, true);
    return;
  }
  void sendCommand(c, parsed.args);
});

async function sendCommand(c: ProtocolCommand, args: number[]): Promise<void> {
  say(cmdMsg, `Sending ${c.name}…`);
  try {
    const reply = await api<CommandReply>("POST", "/api/command", { name: c.name, args });
    $("cmd-status").textContent = reply.status;
    $("cmd-status").className = reply.status === "CONTROL_OK" ? "ok" : "bad";
    const resultNames = names(c.results);
    $("cmd-results").textContent =
      reply.results.length === 0
        ? "none"
        : reply.results
            .map((v, k) => (resultNames.length === reply.results.length ? `${resultNames[k]} = ${v}` : String(v)))
            .join(", ");
    $("cmd-message").textContent = reply.message || "–";
    cmdMsg.textContent = `${c.name} answered.`;
    if (reply.status === "CONTROL_OK") showRawPath(c.name, args);
  } catch (err) {
    say(cmdMsg, errorText(err), true);
  }
}

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
pause.addEventListener("click", () => {
  plots.paused = !plots.paused;
  pause.setAttribute("aria-pressed", String(plots.paused));
  pause.textContent = plots.paused ? "Resume" : "Pause";
});
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

// -- start -------------------------------------------------------------------------------------
renderLink();
void loadMap();
void loadProtocol();
void tuning.load();
void gatewayPanel.load();
void pollStatus();
window.setInterval(() => void pollStatus(), 1000);
connect();
