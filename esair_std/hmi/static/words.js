// Counts in words that agree with the numbers ("1 error", "2 errors"), as
// esair_std/plurals.py's counted() says them for the CLI and the log.
export const counted = (n, word) => `${n} ${word}${n === 1 ? "" : "s"}`;
