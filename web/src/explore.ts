// "Explore" (issue 26): the cart drives to the frontiers of what its camera has seen until none
// can be reached, then the gateway saves the map under the name beside "Save map"
// (POST /api/explore; the stop ends it). Its progress comes as the /ws `exploration` message.
import { api } from "./api";
import { byId as $, say } from "./dom";
import type { ExplorationMessage } from "./generated/live";
import type { PanelContext } from "./tuning";

export function progressText(m: ExplorationMessage): string {
  const time = m.elapsed_sim_s === null ? `${m.elapsed_s.toFixed(0)} s` : `${m.elapsed_sim_s.toFixed(0)} s simulated`;
  const aside = m.set_aside.length ? `, ${m.set_aside.length} set aside` : "";
  const seen = `${m.seen_m2.toFixed(1)} m² seen (${m.seen_percent.toFixed(0)} %)`;
  if (m.state === "exploring") return `Exploring: ${seen}, ${m.frontiers} frontiers${aside}, ${m.goals} goals, ${time}.`;
  if (m.state === "idle") return "";
  const reasons = m.set_aside.map((a) => `(${a.x.toFixed(2)}, ${a.y.toFixed(2)}): ${a.reason}`).join("; ");
  return `${m.sentence} (${seen}, ${time}${reasons ? `; set aside ${reasons}` : ""}).`;
}

export class ExploreButton {
  private readonly button = $<HTMLButtonElement>("explore");
  private readonly msg = $("explore-msg");

  constructor(private readonly ctx: PanelContext) {
    const name = $<HTMLInputElement>("map-save-name");
    this.button.addEventListener("click", () => {
      void (async () => {
        try {
          this.show(await api<ExplorationMessage>("POST", "/api/explore", { save: name.value.trim() }));
        } catch (err) {
          say(this.msg, ctx.errorText(err), true);
        }
      })();
    });
    // a panel opened while the cart explores shows it at once (a replay has no exploration)
    api<ExplorationMessage>("GET", "/api/explore").then((m) => this.show(m), () => undefined);
  }

  show(m: ExplorationMessage): void {
    this.button.disabled = m.state === "exploring";
    say(this.msg, progressText(m), m.state === "failed");
  }
}
