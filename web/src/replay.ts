// `cart2d replay` in the panel: the bar that plays, pauses, seeks and restarts the recording
// (POST /api/replay) with a slider over its time, and what the replay says on /ws. A "replay"
// message with trails (a seek, or this page opening late) replaces the cart's trails with the
// recorded ones up to that time and empties the plots; the state there (map, boxes, mission,
// perceived cells, camera, pose) follows as the ordinary messages the panel already draws.
// A recorded mission's goals come as "goal" messages, said as toasts.

import { api, type GoalMessage, type ReplayMessage, type ReplayView } from "./api";
import { byId as $ } from "./dom";
import type { LiveMap } from "./map";
import type { TelemetryRecord } from "./record";
import type { PanelContext } from "./tuning";

const TICK_MS = 200; // the slider moves this often while playing, between the status polls

export class ReplayBar {
  private readonly bar = $("replay-bar");
  private readonly play = $<HTMLButtonElement>("replay-play");
  private readonly slider = $<HTMLInputElement>("replay-seek");
  private readonly time = $<HTMLOutputElement>("replay-time");
  private view: ReplayView | null = null;
  private viewAtMs = 0; // when `view` came: the position goes on from it while playing
  private dragging = false;

  constructor(
    private readonly ctx: PanelContext,
    private readonly map: LiveMap,
    private readonly record: TelemetryRecord,
  ) {
    this.play.addEventListener("click", () => void this.act(this.view?.state === "playing" ? "pause" : "play"));
    $("replay-restart").addEventListener("click", () => void this.act("restart"));
    this.slider.addEventListener("input", () => {
      this.dragging = true;
      this.showTime(Number(this.slider.value));
    });
    this.slider.addEventListener("change", () => {
      this.dragging = false;
      void this.act("seek", Number(this.slider.value));
    });
    window.setInterval(() => this.render(), TICK_MS);
  }

  /** The replay as /api/status says it (every second), or as an answer to a control. */
  show(view: ReplayView | undefined): void {
    this.bar.hidden = !view;
    if (!view || (this.view && view.version < this.view.version)) return; // an answer overtaken by a change
    this.view = view;
    this.viewAtMs = performance.now();
    this.slider.max = view.duration_s.toFixed(3);
    this.bar.dataset["state"] = view.state;
    this.play.textContent = view.state === "playing" ? "Pause" : "Play";
    this.play.setAttribute("aria-pressed", String(view.state === "playing"));
    this.render();
  }

  /** The replay's /ws messages: its state, and after a seek the trails up to the new time. */
  onMessage(msg: ReplayMessage | GoalMessage): void {
    if (msg.type === "goal") {
      this.sayGoal(msg);
      return;
    }
    if (msg.trail && msg.truth_trail) {
      this.map.clearTrails();
      this.record.clear();
      for (const [x, y] of msg.truth_trail) this.map.setTruth({ x, y, theta: 0 });
      for (const [x, y] of msg.trail) this.map.setPose({ x, y, theta: 0 }); // the pose itself follows
    }
    if (this.view) {
      const { state, position_s, seeks, version } = msg;
      this.show({ ...this.view, state, position_s, seeks, version });
    }
  }

  private async act(action: "play" | "pause" | "restart" | "seek", position_s?: number): Promise<void> {
    try {
      const body = position_s === undefined ? { action } : { action, position_s };
      this.show(await api<ReplayView>("POST", "/api/replay", body));
    } catch (err) {
      this.ctx.notify(this.ctx.errorText(err));
    }
  }

  /** The position now: the last one told, moved on at the replay's speed while it plays. */
  private position(): number {
    const v = this.view;
    if (!v) return 0;
    if (v.state !== "playing") return v.position_s;
    return Math.min(v.duration_s, v.position_s + ((performance.now() - this.viewAtMs) / 1000) * v.speed);
  }

  private render(): void {
    if (!this.view || this.dragging) return;
    const at = this.position();
    this.slider.value = at.toFixed(3);
    this.showTime(at);
  }

  private showTime(at: number): void {
    const v = this.view;
    if (!v) return;
    this.time.textContent = `${at.toFixed(1)} / ${v.duration_s.toFixed(1)} s (${v.state})`;
    this.bar.dataset["position"] = at.toFixed(3);
  }

  private sayGoal(g: GoalMessage): void {
    const which = `Goal ${g.index} of ${g.of} (${g.goal[0].toFixed(2)}, ${g.goal[1].toFixed(2)})`;
    if (g.state === "failed") this.ctx.notify(`${which} failed: ${g.reason ?? ""}`.replace(/: $/, "."));
    else this.ctx.notify(`${which} ${g.state}.`, "info");
  }
}
