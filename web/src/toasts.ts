// Messages about events (a mission arrived or failed, a stop, a lost link): small toasts in a
// corner of the window, out of the flow, so they never move the page under the mouse. They sit
// at the bottom left, unless that would cover one of the controls they must keep clear of (the
// map's mode switch, the command form: a notice above the cards, or scrolling, can bring those
// down there); then at the top left, under the top bar. At most MAX_SHOWN at once, the oldest
// leaving first; each can be dismissed; an error stays longer, and one that is no longer true is
// taken away (dismiss). What a form's own action answers is said in that form's message line
// instead, once.

const MAX_SHOWN = 3;
const ERROR_MS = 10_000;
const INFO_MS = 4_000;
const MARGIN_PX = 12;

export type Kind = "error" | "info";

interface Span {
  top: number;
  bottom: number;
  left: number;
  right: number;
}

const overlaps = (a: Span, b: Span): boolean => a.left < b.right && b.left < a.right && a.top < b.bottom && b.top < a.bottom;

export class Toasts {
  private placing = false;

  /** `keepClear`: selectors of what a toast must not cover; `bar`: the top bar they stay under. */
  constructor(
    private readonly box: HTMLElement,
    private readonly keepClear: string[],
    private readonly bar: HTMLElement,
  ) {
    const later = (): void => {
      if (this.placing) return;
      this.placing = true;
      requestAnimationFrame(() => {
        this.placing = false;
        this.place();
      });
    };
    window.addEventListener("scroll", later, { passive: true });
    window.addEventListener("resize", later);
  }

  show(text: string, kind: Kind = "error", ttlMs = kind === "error" ? ERROR_MS : INFO_MS): void {
    for (const old of this.box.querySelectorAll<HTMLElement>(".msg")) {
      if (old.dataset["text"] === text) old.remove(); // the same sentence once, freshest last
    }
    const item = document.createElement("div");
    item.className = `msg msg-${kind}`;
    item.dataset["text"] = text;
    item.setAttribute("role", kind === "error" ? "alert" : "status");
    const span = document.createElement("span");
    span.textContent = text;
    const close = document.createElement("button");
    close.type = "button";
    close.className = "msg-close";
    close.setAttribute("aria-label", "dismiss this message");
    close.textContent = "×";
    const remove = (): void => {
      item.remove();
      this.place();
    };
    close.addEventListener("click", remove);
    item.append(span, close);
    this.box.append(item);
    while (this.box.children.length > MAX_SHOWN) this.box.firstElementChild?.remove();
    this.place();

    // A message being read (the pointer on it) stays until the pointer leaves it.
    let timer = window.setTimeout(remove, ttlMs);
    item.addEventListener("pointerenter", () => window.clearTimeout(timer));
    item.addEventListener("pointerleave", () => {
      timer = window.setTimeout(remove, INFO_MS);
    });
  }

  /** Takes away the message saying `text`, if it is shown: what it said is no longer true. */
  dismiss(text: string): void {
    for (const old of this.box.querySelectorAll<HTMLElement>(".msg")) {
      if (old.dataset["text"] === text) old.remove();
    }
    this.place();
  }

  /** Bottom left, or top left when only that keeps the controls to keep clear uncovered. */
  private place(): void {
    const own = this.box.getBoundingClientRect();
    if (own.height === 0) return;
    const clear = this.keepClear
      .flatMap((s) => [...document.querySelectorAll(s)])
      .map((e) => e.getBoundingClientRect())
      .filter((r) => r.width > 0 && r.bottom > 0 && r.top < window.innerHeight);
    const hits = (top: number): boolean => clear.some((r) => overlaps({ top, bottom: top + own.height, left: own.left, right: own.right }, r));
    const barBottom = Math.max(0, this.bar.getBoundingClientRect().bottom);
    const atTop = hits(window.innerHeight - MARGIN_PX - own.height) && !hits(barBottom + MARGIN_PX);
    this.box.classList.toggle("at-top", atTop);
    this.box.style.top = atTop ? `${barBottom + MARGIN_PX}px` : "";
  }
}
