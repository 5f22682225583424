// The notice after the controller restarted (cart2d/gateway/): what happened, in the gateway's
// words, and the three ways to give the gateway a pose it can plan from again: set the pose
// (x, y, θ), run the reset routine, or accept the pose the firmware has. It sits above the page,
// in the flow: everything else keeps working (stop, manual driving, the command form).

import { api, type Pose, type PoseTrust, type ResetReport, type RoutineView, type StatusView } from "./api";
import { byId, say } from "./dom";
import { parseNumber } from "./parse";
import type { PanelContext } from "./tuning";

const deg = (rad: number): number => (rad * 180) / Math.PI;

/** A number with `digits` decimals, without the sign of a value that rounds to zero. */
function fixed(v: number, digits: number): string {
  const text = v.toFixed(digits);
  return Number(text) === 0 ? (0).toFixed(digits) : text;
}

function poseText(p: Pose): string {
  return `(${fixed(p.x, 3)} m, ${fixed(p.y, 3)} m, ${fixed(deg(p.theta), 1)}°)`;
}

/** The pose typed in the form (θ in degrees), or a sentence saying what is wrong with it. */
export function checkPose(x: string, y: string, thetaDeg: string): Pose | { error: string } {
  const px = parseNumber(x, "x");
  if (!px.ok) return { error: px.message };
  const py = parseNumber(y, "y");
  if (!py.ok) return { error: py.message };
  const pt = parseNumber(thetaDeg, "θ");
  if (!pt.ok) return { error: pt.message };
  if (Math.abs(pt.value) > 360) return { error: `θ is in degrees, from −360 to 360: not ${pt.value}.` };
  return { x: px.value, y: py.value, theta: (pt.value * Math.PI) / 180 };
}

export class RestartNotice {
  private readonly root = byId("reset-notice");
  private readonly text = byId("reset-notice-text");
  private readonly acceptHint = byId("accept-hint");
  private readonly msg = byId<HTMLOutputElement>("reset-notice-msg");
  private readonly form = byId<HTMLFormElement>("pose-form");
  private last: ResetReport | null = null;

  constructor(private readonly ctx: PanelContext) {
    this.form.addEventListener("submit", (e) => {
      e.preventDefault();
      const field = (n: string): string => (this.form.elements.namedItem(n) as HTMLInputElement).value;
      const pose = checkPose(field("x"), field("y"), field("theta"));
      if ("error" in pose) {
        say(this.msg, pose.error, true);
        return;
      }
      void this.act("POST", "/api/pose", pose, "Setting the pose…");
    });
    byId("run-routine").addEventListener("click", () => {
      void this.act("POST", "/api/pose/reset-routine", undefined, "Starting the reset routine…");
    });
    byId("accept-pose").addEventListener("click", () => {
      void this.act("POST", "/api/pose/accept", undefined, "Accepting the firmware's pose…");
    });
    this.render({ trusted: true, reason: "" });
  }

  /** From GET /api/status (every second): catches a restart whose live message was missed. */
  update(s: StatusView): void {
    this.last = s.reset.last;
    this.render(s.pose_trust);
    if (s.routine.state === "running") this.showRoutine(s.routine);
  }

  /** The live message of a restart: the notice if the pose is no longer trusted, else a note. */
  onReset(report: ResetReport, trust: PoseTrust): void {
    this.last = report;
    say(this.msg, "");
    this.render(trust);
    if (trust.trusted) this.ctx.notify(report.message, "info");
  }

  onPoseTrust(trust: PoseTrust, how: string): void {
    const wasShown = !this.root.hidden;
    this.render(trust);
    if (trust.trusted && wasShown) this.ctx.notify(`${how.charAt(0).toUpperCase()}${how.slice(1)}.`, "info");
  }

  onRoutine(routine: RoutineView): void {
    this.showRoutine(routine);
  }

  private showRoutine(routine: RoutineView): void {
    if (this.root.hidden) return;
    this.root.dataset["routine"] = routine.state;
    if (routine.state === "running") say(this.msg, `The reset routine is running: ${routine.words}…`);
    else if (routine.state === "failed") say(this.msg, `The reset routine did not end squared up: ${routine.words}.`, true);
  }

  private render(trust: PoseTrust): void {
    document.body.dataset["poseTrusted"] = String(trust.trusted);
    const show = !trust.trusted;
    if (show && this.root.hidden) {
      for (const name of ["x", "y", "theta"]) (this.form.elements.namedItem(name) as HTMLInputElement).value = "";
      delete this.root.dataset["routine"];
    }
    this.root.hidden = !show;
    if (!show) return;
    const r = this.last;
    this.text.textContent = r ? r.message : `The gateway does not trust the pose: ${trust.reason}.`;
    if (r?.pose) {
      this.acceptHint.textContent = r.pose_restored
        ? `Accepting keeps the pose the firmware restored from RAM, ${poseText(r.pose)}: the pose at the reset, blind to any motion during it.`
        : `Accepting keeps the firmware's pose, counted from (0, 0, 0) where it restarted: ${poseText(r.pose)} when the restart was noticed.`;
    } else {
      this.acceptHint.textContent = "Accepting keeps the pose the firmware has now.";
    }
  }

  private async act(method: string, path: string, body: unknown, doing: string): Promise<void> {
    say(this.msg, doing);
    try {
      const answer = await api<{ words?: string; routine?: RoutineView }>(method, path, body);
      if (answer.routine) this.showRoutine(answer.routine);
      else say(this.msg, "");
    } catch (err) {
      say(this.msg, this.ctx.errorText(err), true);
    }
  }
}
