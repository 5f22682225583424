// The fleet page's table of carts: one row per cart, kept from one refresh to the next (so a
// button under the pointer is not replaced while it is clicked), with its pause/resume and
// cancel buttons.

import type { CartView } from "./generated/fleet";
import { colourOf } from "./fleet_map";

export interface CartActions {
  pause: (cart: string, paused: boolean) => void;
  cancel: (cart: string) => void;
}

const FIELDS = ["state", "pose", "order", "holds", "waits"] as const;
type Field = (typeof FIELDS)[number];

function poseText(cart: CartView): string {
  if (!cart.position) return "–";
  const [x, y, theta] = cart.position;
  return `${x.toFixed(2)}, ${y.toFixed(2)} m, ${Math.round((theta * 180) / Math.PI)}°`;
}

function button(text: string, title: string, onClick: () => void): HTMLButtonElement {
  const b = document.createElement("button");
  b.type = "button";
  b.className = "small";
  b.textContent = text;
  b.title = title;
  b.addEventListener("click", onClick);
  return b;
}

class CartRow {
  readonly row = document.createElement("tr");
  private readonly cells = new Map<Field, HTMLTableCellElement>();
  private readonly swatch = document.createElement("span");
  private readonly pause: HTMLButtonElement;
  private readonly cancel: HTMLButtonElement;
  private paused = false;

  constructor(name: string, actions: CartActions) {
    this.row.dataset["cart"] = name;
    const nameCell = document.createElement("td");
    this.swatch.className = "sw";
    nameCell.append(this.swatch, name);
    this.row.append(nameCell);
    for (const field of FIELDS) {
      const td = document.createElement("td");
      td.dataset["field"] = field;
      this.cells.set(field, td);
      this.row.append(td);
    }
    this.pause = button("Pause", "startPause: it stops where it is, keeping its order", () => actions.pause(name, !this.paused));
    this.cancel = button("Cancel", "cancelOrder: its goal is dropped; it keeps the node it stands on", () => actions.cancel(name));
    const buttons = document.createElement("td");
    buttons.className = "cart-actions";
    buttons.append(this.pause, this.cancel);
    this.row.append(buttons);
  }

  show(cart: CartView, colour: string): void {
    this.row.dataset["state"] = cart.state;
    this.swatch.style.background = colour;
    const state = this.cell("state");
    state.className = `cart-state state-${cart.state}`;
    state.title = `connection ${cart.connection}`;
    state.textContent = cart.state;
    if (cart.errors.length > 0) {
      const errors = document.createElement("span");
      errors.className = "cart-errors";
      errors.textContent = cart.errors.map((e) => `${e.type}: ${e.description}`).join("; ");
      state.append(errors);
    }
    if (cart.off_traffic !== null) {
      const off = document.createElement("span");
      off.className = "cart-errors cart-off-traffic";
      off.textContent = `off the traffic: ${cart.off_traffic}`;
      state.append(off);
    }
    this.cell("pose").textContent = poseText(cart);
    this.cell("order").textContent = cart.order_id ? `${cart.order_id} (goal ${cart.goal ?? "–"})` : "–";
    this.cell("holds").textContent = String(cart.held.length);
    this.cell("waits").textContent = cart.waiting_for ?? "–";
    this.paused = cart.state === "paused";
    this.pause.textContent = this.paused ? "Resume" : "Pause";
    this.pause.title = this.paused ? "stopPause: it drives on with its order" : "startPause: it stops where it is, keeping its order";
  }

  private cell(field: Field): HTMLTableCellElement {
    const td = this.cells.get(field);
    if (!td) throw new Error(`a cart row has no ${field}`);
    return td;
  }
}

export class CartTable {
  private readonly rows = new Map<string, CartRow>();

  constructor(
    private readonly body: HTMLElement,
    private readonly actions: CartActions,
  ) {}

  show(carts: CartView[]): void {
    const names = carts.map((c) => c.name).sort();
    for (const name of [...this.rows.keys()]) if (!names.includes(name)) this.rows.delete(name);
    const ordered = [...carts].sort((a, b) => a.name.localeCompare(b.name));
    for (const cart of ordered) {
      let row = this.rows.get(cart.name);
      if (!row) {
        row = new CartRow(cart.name, this.actions);
        this.rows.set(cart.name, row);
      }
      row.show(cart, colourOf(cart.name, names));
    }
    const wanted = ordered.map((c) => this.rows.get(c.name)?.row).filter((r): r is HTMLTableRowElement => r !== undefined);
    const now = [...this.body.children];
    if (wanted.length !== now.length || wanted.some((r, i) => r !== now[i])) this.body.replaceChildren(...wanted);
  }
}
