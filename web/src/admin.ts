// The gateway panel: network settings (applied at restart), soft reset, the settings file
// (download and upload) and the firmware update (upload a .hex, follow its job to the end).

import { api, Raw, type GatewaySettings, type ResetReport, type UpdateJob } from "./api";
import { byId, say } from "./dom";
import type { PanelContext } from "./tuning";

const MAX_BYTES = 256 * 1024; // the gateway's largest request body

/** The host and port typed, or a sentence saying what is wrong with them. */
function checkNetwork(host: string, port: string): { host: string; port: number } | { error: string } {
  const h = host.trim();
  if (h === "") return { error: "The host is empty: type an address such as 127.0.0.1 or 0.0.0.0." };
  if (h.length > 253 || /[\s/]/.test(h)) return { error: `The host “${h}” is not an address or host name.` };
  const p = port.trim();
  if (!/^\d+$/.test(p)) return { error: `The port is not a whole number: “${p}”.` };
  const n = Number(p);
  if (n < 1 || n > 65535) return { error: `The port must be between 1 and 65535, not ${n}.` };
  return { host: h, port: n };
}

export class GatewayPanel {
  private polling: number | null = null;

  constructor(private readonly ctx: PanelContext) {
    const netForm = byId<HTMLFormElement>("net-form");
    const netMsg = byId<HTMLOutputElement>("net-msg");
    netForm.addEventListener("submit", (e) => {
      e.preventDefault();
      const field = (n: string): string => (netForm.elements.namedItem(n) as HTMLInputElement).value;
      const checked = checkNetwork(field("host"), field("port"));
      if ("error" in checked) {
        say(netMsg, checked.error, true);
        return;
      }
      void (async () => {
        try {
          await api("PUT", "/api/settings/network", checked);
          say(netMsg, `Saved ${checked.host}:${checked.port}: it takes effect when the gateway restarts.`);
        } catch (err) {
          say(netMsg, this.ctx.errorText(err), true);
        }
      })();
    });

    byId("reset-mcu").addEventListener("click", () => {
      void (async () => {
        try {
          const answer = await api<{ result: string; reset: ResetReport | null }>("POST", "/api/reset", undefined, 10_000);
          this.ctx.notify(
            answer.reset
              ? `Soft reset: the controller restarted. ${
                  answer.reset.pose_restored
                    ? "The firmware restored its pose from RAM (the pose at the reset)."
                    : "Its odometry restarted at (0, 0, 0), not at the reset pose."
                }`
              : "Soft reset sent, but no restart was seen within 5 s: watch the status bar.",
            "info",
          );
        } catch (err) {
          this.ctx.notify(this.ctx.errorText(err));
        }
      })();
    });

    const fileForm = byId<HTMLFormElement>("settings-file-form");
    const fileMsg = byId<HTMLOutputElement>("settings-file-msg");
    fileForm.addEventListener("submit", (e) => {
      e.preventDefault();
      const file = (fileForm.elements.namedItem("file") as HTMLInputElement).files?.[0];
      void this.uploadSettings(file, fileMsg);
    });

    const fwForm = byId<HTMLFormElement>("fw-update-form");
    fwForm.addEventListener("submit", (e) => {
      e.preventDefault();
      const file = (fwForm.elements.namedItem("file") as HTMLInputElement).files?.[0];
      void this.uploadFirmware(file);
    });
  }

  /** The network form filled from the gateway's settings. */
  async load(): Promise<void> {
    try {
      const s = await api<GatewaySettings>("GET", "/api/settings");
      const form = byId<HTMLFormElement>("net-form");
      (form.elements.namedItem("host") as HTMLInputElement).value = s.network.host;
      (form.elements.namedItem("port") as HTMLInputElement).value = String(s.network.port);
    } catch (err) {
      this.ctx.notify(this.ctx.errorText(err));
    }
  }

  private async uploadSettings(file: File | undefined, out: HTMLOutputElement): Promise<void> {
    if (!file) return say(out, "Choose a settings file first (one downloaded from this page).", true);
    if (file.size === 0 || file.size > MAX_BYTES) {
      return say(out, `${file.name} is ${file.size === 0 ? "empty" : "too large"}: a settings file is JSON of at most 256 KiB.`, true);
    }
    const text = await file.text();
    try {
      JSON.parse(text);
    } catch {
      return say(out, `${file.name} is not JSON: choose a settings file downloaded from this page.`, true);
    }
    try {
      await api("POST", "/api/settings/file", new Raw(text, "application/json"), 30_000);
      say(out, `Imported ${file.name}: the map changed now; network changes take effect when the gateway restarts.`);
      window.dispatchEvent(new Event("cart2d-settings-imported"));
      await this.load();
    } catch (err) {
      say(out, this.ctx.errorText(err), true);
    }
  }

  private async uploadFirmware(file: File | undefined): Promise<void> {
    const out = byId<HTMLOutputElement>("fw-update-msg");
    if (this.polling !== null) return say(out, "A firmware update is already running.", true);
    if (!file) return say(out, "Choose a .hex file first (make firmware builds build/firmware/cart2d-nano.hex).", true);
    if (!/\.hex$/i.test(file.name)) return say(out, `${file.name} is not a .hex file.`, true);
    if (file.size === 0 || file.size > MAX_BYTES) {
      return say(out, `${file.name} is ${file.size === 0 ? "empty" : "too large for the gateway (256 KiB at most)"}.`, true);
    }
    const text = await file.text();
    if (!text.startsWith(":")) return say(out, `${file.name} is not an Intel HEX file: its first line does not start with “:”.`, true);
    say(out, `Uploading ${file.name}…`);
    try {
      const job = await api<UpdateJob>("POST", "/api/firmware/update", new Raw(file, "application/octet-stream"), 30_000);
      this.show(job);
    } catch (err) {
      say(out, this.ctx.errorText(err), true);
      return;
    }
    this.polling = window.setInterval(() => void this.poll(), 300);
  }

  private async poll(): Promise<void> {
    try {
      this.show(await api<UpdateJob>("GET", "/api/firmware/update", undefined, 4000));
    } catch (err) {
      say(byId<HTMLOutputElement>("fw-update-msg"), this.ctx.errorText(err), true);
    }
  }

  private show(job: UpdateJob): void {
    const box = byId("fw-update");
    box.dataset["state"] = job.state;
    byId("fw-update-state").textContent = `${job.state} (${job.elapsed_s.toFixed(1)} s)`;
    byId("fw-update-log").textContent = job.log.join("\n");
    const bar = byId<HTMLProgressElement>("fw-update-progress");
    bar.hidden = job.state !== "running";
    const out = byId<HTMLOutputElement>("fw-update-msg");
    if (job.state === "running") return;
    if (this.polling !== null) window.clearInterval(this.polling);
    this.polling = null;
    if (job.state === "done") say(out, "The new firmware is running.");
    else if (job.state === "failed") say(out, `The update failed: ${job.error || "see the log"}.`, true);
  }
}
