// Small helpers on the page shared by the panel's modules: finding an element, a form's message
// line, and the colours the stylesheet sets (custom properties, which dark mode changes).

/** The element with id `id` (inside `within` if given); throws if the page lacks it. */
export function byId<T extends HTMLElement = HTMLElement>(id: string, within?: HTMLElement): T {
  const found = within ? within.querySelector<T>(`#${CSS.escape(id)}`) : document.getElementById(id);
  if (!found) throw new Error(`the ${within ? `#${within.id}` : "page"} has no #${id}`);
  return found as T;
}

/** A form's message line: `text`, shown as an error or as a note. */
export function say(out: HTMLElement, text: string, error = false): void {
  out.textContent = text;
  out.className = error ? "form-msg form-error" : "form-msg";
}

/** A CSS custom property of the page, or `fallback` when unset; pass `style` (the page's computed
 * style) to read several without computing it again each time. */
export function cssVar(
  name: string,
  fallback: string,
  style: CSSStyleDeclaration = getComputedStyle(document.documentElement),
): string {
  return style.getPropertyValue(name).trim() || fallback;
}
