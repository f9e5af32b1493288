// Small DOM helpers shared by the page's modules. Text always goes in as text (textContent),
// never as HTML: file names, questions, programs and error bodies come from elsewhere.

export const $ = (id) => document.getElementById(id);

export function element(tag, { dataset, ...props } = {}, ...children) {
  const node = Object.assign(document.createElement(tag), props);
  if (dataset) Object.assign(node.dataset, dataset);
  node.append(...children.filter((c) => c !== null && c !== undefined));
  return node;
}

// "12 s", "1 min 05 s": the clock and the timings in words people read at a glance.
export function duration(seconds) {
  const whole = Math.floor(seconds);
  if (whole < 60) return `${whole} s`;
  return `${Math.floor(whole / 60)} min ${String(whole % 60).padStart(2, "0")} s`;
}

export function megabytes(bytes) {
  return `${(bytes / 1e6).toFixed(bytes < 1e5 ? 2 : 1)} MB`;
}
