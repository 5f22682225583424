// Numbers typed by a person: refused in the page, with a sentence, before anything is sent.

/** The protocol's range (docs/protocol.md): finite, magnitude below 2^20. */
const LIMIT = 1048576;

const NUMBER = /^[+-]?(\d+\.?\d*|\.\d+)(e[+-]?\d+)?$/i;

export type Parsed = { ok: true; value: number } | { ok: false; message: string };

/** A decimal number in `text` ("1.5", "-2", "3e-2"; a comma decimal separator is accepted). */
export function parseNumber(text: string, what: string): Parsed {
  const s = text.trim().replace(/^([+-]?\d*),(\d+)$/, "$1.$2");
  if (s === "") return { ok: false, message: `${what} is empty: type a number.` };
  if (!NUMBER.test(s)) return { ok: false, message: `${what} is not a number: “${text.trim()}”.` };
  const value = Number(s);
  if (!Number.isFinite(value)) return { ok: false, message: `${what} is not a finite number.` };
  if (Math.abs(value) >= LIMIT) {
    return { ok: false, message: `${what} is out of range: its magnitude must be below ${LIMIT}.` };
  }
  return { ok: true, value };
}
