// The fleet page (`cart2d fleet`, fleet.html): every cart on one live map with its state, a
// click on the map a goal (for the nearest idle cart or the one chosen), a pause and a cancel per
// cart, STOP ALL, and what the manager refuses said in a sentence. Its data is the manager's JSON (cart2d/fleet/views.py,
// generated into ./generated/fleet.ts), pushed by its live stream (/ws, fleet_stream.ts) and
// polled only while that is down.

import "./style.css";
import "./fleet.css";
import { api, ApiError, type Point } from "./api";
import { byId as $, say } from "./dom";
import { CartTable } from "./fleet_carts";
import { FleetMap } from "./fleet_map";
import { FleetStream } from "./fleet_stream";
import type { CartAnswer, FleetView, GoalAccepted, GoalRequest, GoalView, PauseRequest, StopAnswer } from "./generated/fleet";

const REFRESH_MS = 250; // the poll's period while the stream is down
const SHOWN_GOALS = 30;

const message = $<HTMLOutputElement>("fleet-msg");
const chooser = $<HTMLSelectElement>("goal-cart");

/** The manager's refusal (its 4xx detail) or why it could not be asked, as a sentence. */
function refusal(err: unknown): string {
  if (err instanceof ApiError) return err.status === 0 ? "The fleet manager does not answer: is cart2d fleet running?" : err.message;
  return String(err);
}

async function sendGoal([x, y]: Point): Promise<void> {
  const cart = chooser.value;
  const body: GoalRequest = cart ? { x, y, cart } : { x, y };
  try {
    const goal = await api<GoalAccepted>("POST", "/api/fleet/goals", body);
    const [gx, gy] = goal.at;
    say(message, `Goal ${goal.id} at (${gx.toFixed(2)}, ${gy.toFixed(2)}) for ${goal.cart ?? "the nearest idle cart"}.`);
  } catch (err) {
    say(message, refusal(err), true);
  }
}

async function stopAll(): Promise<void> {
  try {
    await api<StopAnswer>("POST", "/api/fleet/stop");
    say(message, "STOP ALL: every cart stopped, its order cancelled.");
  } catch (err) {
    say(message, refusal(err), true);
  }
}

function goalItem(goal: GoalView): HTMLLIElement {
  const item = document.createElement("li");
  item.value = goal.id;
  item.dataset["goal"] = String(goal.id);
  item.dataset["status"] = goal.status;
  item.className = `goal-${goal.status}`;
  const [x, y] = goal.at;
  const waited = goal.waited_s > 0 ? `, waited ${goal.waited_s.toFixed(1)} s` : "";
  const why = goal.reason !== null && (goal.status === "waiting" || goal.status === "failed") ? ` (${goal.reason})` : "";
  item.textContent = `(${x.toFixed(2)}, ${y.toFixed(2)}) ${goal.cart ?? "unassigned"}: ${goal.status}${waited}${why}`;
  return item;
}

/** The chooser keeps what the user chose while the carts are refreshed. */
function showChoices(names: string[]): void {
  const now = [...chooser.options].slice(1).map((o) => o.value);
  if (now.join("\n") === names.join("\n")) return;
  const chosen = chooser.value;
  chooser.replaceChildren(chooser.options[0] ?? new Option("the nearest idle cart", ""));
  for (const name of names) chooser.append(new Option(name, name, false, name === chosen));
}

async function toCart(cart: string, action: "cancel" | "pause", body?: PauseRequest): Promise<void> {
  try {
    const answer = await api<CartAnswer>("POST", `/api/fleet/carts/${encodeURIComponent(cart)}/${action}`, body);
    say(message, `${answer.sent} sent to ${answer.cart}.`);
  } catch (err) {
    say(message, refusal(err), true);
  }
}

const table = new CartTable($("carts"), {
  pause: (cart, paused) => void toCart(cart, "pause", { paused }),
  cancel: (cart) => void toCart(cart, "cancel"),
});

function show(fleet: FleetView, map: FleetMap): void {
  const names = fleet.carts.map((c) => c.name).sort();
  map.show(fleet);
  table.show(fleet.carts);
  $("no-carts").hidden = fleet.carts.length > 0;
  $("goals").replaceChildren(...fleet.goals.slice(-SHOWN_GOALS).reverse().map(goalItem));
  showChoices(names);
  const online = fleet.carts.filter((c) => c.connection === "ONLINE").length;
  $("carts-online").textContent = `${online} of ${fleet.carts.length}`;
  $("goals-reached").textContent = `${fleet.goals.filter((g) => g.status === "reached").length} of ${fleet.goals.length}`;
  $("deadlocks").textContent = String(fleet.deadlocks);
  $("contacts-item").hidden = !fleet.truth;
  if (fleet.truth) $("contacts").textContent = String(fleet.truth.cart_contacts);
}

function connected(ok: boolean, words: string, feed: "stream" | "polling"): void {
  $("manager-dot").className = `dot ${ok ? "dot-connected" : "dot-lost"}`;
  $("manager-state").textContent = words;
  document.body.dataset["manager"] = ok ? "connected" : "lost";
  document.body.dataset["feed"] = feed;
}

/** Polls while the stream is down; a view the stream brings makes the poll wait. */
async function refresh(map: FleetMap, stream: FleetStream): Promise<void> {
  if (!stream.live) {
    try {
      const view = await api<FleetView>("GET", "/api/fleet", undefined, 3000);
      if (!stream.live) {
        show(view, map);
        connected(true, "manager connected (polling)", "polling");
      }
    } catch (err) {
      if (!stream.live) connected(false, refusal(err), "polling");
    }
  }
  setTimeout(() => void refresh(map, stream), REFRESH_MS);
}

const map = new FleetMap($<HTMLCanvasElement>("map"), (p) => void sendGoal(p));
const stream = new FleetStream(
  (view) => {
    show(view, map);
    connected(true, "manager connected (live)", "stream");
  },
  (live) => {
    if (!live) document.body.dataset["feed"] = "polling";
  },
);
$("stop-all").addEventListener("click", () => void stopAll());
document.addEventListener("keydown", (e) => {
  if (e.key === "Escape") void stopAll(); // a stop always goes first, from anywhere on the page
});
stream.connect();
void refresh(map, stream);
