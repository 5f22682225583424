// The access token of a gateway bound off loopback (SECURITY.md): the form that asks for it,
// checks it against the live stream before keeping it, and the stream's address with it.

import { api, setToken } from "./api";
import { byId, say } from "./dom";
import type { PanelContext } from "./tuning";

/** The URL of the gateway's live stream, with `accessToken` if there is one. */
export function wsUrl(accessToken: string | null): string {
  const proto = location.protocol === "https:" ? "wss:" : "ws:";
  return `${proto}//${location.host}/ws${accessToken ? `?token=${encodeURIComponent(accessToken)}` : ""}`;
}

/** Whether the gateway answers HTTP now (then a refused WebSocket handshake was about the token). */
export async function gatewayAnswers(): Promise<boolean> {
  try {
    await api("GET", "/api/status", undefined, 3000);
    return true;
  } catch {
    return false;
  }
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

export class TokenForm {
  private readonly form = byId<HTMLFormElement>("token-form");
  private readonly msg = byId<HTMLOutputElement>("token-msg");

  /** `accepted`: called once a token the gateway takes is kept. */
  constructor(ctx: PanelContext, accepted: () => void) {
    this.form.addEventListener("submit", (e) => {
      e.preventDefault();
      const input = this.form.elements.namedItem("token") as HTMLInputElement;
      const value = input.value.trim();
      if (value.length < 16) {
        say(this.msg, "The access token is at least 16 characters: copy it from the gateway's terminal.", true);
        return;
      }
      say(this.msg, "Checking the token…");
      void checkToken(value).then((verdict) => {
        if (verdict === "refused") {
          input.value = "";
          say(this.msg, "That is not this gateway's access token: copy it from the terminal where cart2d runs.", true);
          return;
        }
        if (verdict === "unreachable") {
          say(this.msg, "The gateway cannot be reached to check the token: try again.", true);
          return;
        }
        setToken(value);
        input.value = "";
        say(this.msg, "");
        this.form.hidden = true;
        ctx.notify("Token accepted and saved in this browser: changes are allowed now.", "info");
        accepted();
      });
    });
    byId("token-later").addEventListener("click", () => {
      this.form.hidden = true;
      say(this.msg, "");
    });
  }

  show(): void {
    this.form.hidden = false;
  }
}
