// summary.json as a table of its main figures, and whole below it.

const ROWS = [
  ['status', 'status'], ['message', 'message'], ['scene', 'scene'], ['method', 'method'], ['alpha', 'alpha'],
  ['dt (s)', 'dt'], ['duration (s)', 'duration'], ['frame interval (s)', 'frame_interval'], ['frames', 'frames'],
  ['vertices', 'vertices'], ['triangles', 'triangles'], ['steps', 'steps'], ['wall time (s)', 'wall_seconds'],
  ['solver iterations, mean', 'solver_iterations_mean'], ['solver failures', 'solver_failures'],
  ['damping ratio', 'damping_ratio'], ['added viscosity, max (N s/m)', 'added_viscosity_Ns_m.max'],
  ['node contacts, mean', 'contacts.node_contacts_mean'], ['contact work (J)', 'contacts.work_J'],
  ['intersections, total', 'intersections.total'], ['formats', 'formats'],
];

function lookup(object, path) {
  return path.split('.').reduce((o, key) => (o !== null && typeof o === 'object' ? o[key] : undefined), object);
}

function format(value) {
  if (typeof value === 'number') return Number.isInteger(value) ? String(value) : value.toPrecision(4);
  if (Array.isArray(value)) return value.join(', ');
  if (value !== null && typeof value === 'object') return JSON.stringify(value);
  return String(value);
}

export function showSummary(table, pre, text) {
  if (text === null) {
    table.textContent = 'no summary.json';
    return;
  }
  const summary = JSON.parse(text);
  pre.textContent = JSON.stringify(summary, null, 2);
  for (const [label, path] of ROWS) {
    const value = lookup(summary, path);
    if (value === undefined) continue;
    const row = table.insertRow();
    row.insertCell().textContent = label;
    row.insertCell().textContent = format(value);
  }
}
