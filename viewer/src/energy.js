// The energy curves of energy.csv (one row per frame: time, then energies in J) drawn on a
// canvas, with a cursor at the current time; a click or drag on the chart seeks there.

const COLOURS = {
  kinetic: '#d62728', elastic: '#2ca02c', gravity: '#1f77b4', total: '#222222', viscous_dissipated: '#9467bd',
  numerical_dissipated: '#8c564b', contact_work: '#e377c2',
};
const FALLBACK = ['#17becf', '#bcbd22', '#7f7f7f', '#ff7f0e'];

function parseCsv(text) {
  const lines = text.trim().split(/\r?\n/);
  const names = lines[0].split(',').map((s) => s.trim());
  const columns = names.map(() => []);
  for (const line of lines.slice(1)) {
    const cells = line.split(',');
    if (cells.length !== names.length) continue;
    cells.forEach((c, k) => columns[k].push(Number(c)));
  }
  return {names, columns};
}

export class EnergyChart {
  constructor(canvas, keys, csvText, onSeek) {
    this.canvas = canvas;
    const {names, columns} = parseCsv(csvText);
    const timeColumn = names.indexOf('time');
    this.times = columns[timeColumn] || [];
    // The guard's columns (a count of parts and an alpha) are not energies.
    this.series = names.map((name, k) => ({name, values: columns[k]}))
        .filter((s, k) => k !== timeColumn && !s.name.startsWith('guard_'));
    this.series.forEach((s, k) => { s.colour = COLOURS[s.name] || FALLBACK[k % FALLBACK.length]; });
    keys.replaceChildren(...this.series.map((s) => {
      const span = document.createElement('span');
      const swatch = document.createElement('i');
      swatch.style.background = s.colour;
      span.append(swatch, s.name.replace(/_/g, ' '));
      return span;
    }));
    const ratio = window.devicePixelRatio || 1;
    this.width = canvas.clientWidth || canvas.width;
    this.height = canvas.clientHeight || canvas.height;
    canvas.width = Math.round(this.width * ratio);
    canvas.height = Math.round(this.height * ratio);
    this.context = canvas.getContext('2d');
    this.context.scale(ratio, ratio);
    this.plot = {left: 52, right: this.width - 8, top: 8, bottom: this.height - 22};
    this.t0 = this.times.length ? this.times[0] : 0;
    this.t1 = this.times.length ? this.times[this.times.length - 1] : 1;
    if (!(this.t1 > this.t0)) this.t1 = this.t0 + 1;
    let lo = Infinity, hi = -Infinity;
    for (const s of this.series) for (const v of s.values) if (Number.isFinite(v)) lo = Math.min(lo, v), hi = Math.max(hi, v);
    if (!(hi > lo)) lo = Number.isFinite(lo) ? lo - 1 : 0, hi = lo + 2;
    const pad = 0.04 * (hi - lo);
    this.lo = lo - pad;
    this.hi = hi + pad;
    this.background = null;
    this.drawCurves();
    const seekAt = (e) => {
      const r = canvas.getBoundingClientRect();
      const x = (e.clientX - r.left) / r.width * this.width;
      onSeek(this.t0 + (x - this.plot.left) / (this.plot.right - this.plot.left) * (this.t1 - this.t0));
    };
    canvas.addEventListener('pointerdown', (e) => { canvas.setPointerCapture(e.pointerId); seekAt(e); });
    canvas.addEventListener('pointermove', (e) => { if (e.buttons & 1) seekAt(e); });
  }

  x(t) { return this.plot.left + (t - this.t0) / (this.t1 - this.t0) * (this.plot.right - this.plot.left); }
  y(v) { return this.plot.bottom - (v - this.lo) / (this.hi - this.lo) * (this.plot.bottom - this.plot.top); }

  drawCurves() {
    const g = this.context, p = this.plot;
    g.clearRect(0, 0, this.width, this.height);
    g.font = '10px system-ui, sans-serif';
    g.fillStyle = '#555';
    g.strokeStyle = '#ddd';
    g.lineWidth = 1;
    for (let k = 0; k <= 4; ++k) {
      const v = this.lo + (this.hi - this.lo) * k / 4, y = this.y(v);
      g.beginPath(); g.moveTo(p.left, y); g.lineTo(p.right, y); g.stroke();
      g.textAlign = 'right'; g.textBaseline = 'middle';
      g.fillText(Math.abs(v) >= 1e4 || (Math.abs(v) < 1e-2 && v !== 0) ? v.toExponential(1) : v.toPrecision(3), p.left - 4, y);
    }
    for (let k = 0; k <= 4; ++k) {
      const t = this.t0 + (this.t1 - this.t0) * k / 4;
      g.textAlign = 'center'; g.textBaseline = 'top';
      g.fillText(`${t.toPrecision(3)} s`, this.x(t), p.bottom + 4);
    }
    g.strokeStyle = '#999';
    g.strokeRect(p.left, p.top, p.right - p.left, p.bottom - p.top);
    for (const s of this.series) {
      g.strokeStyle = s.colour;
      g.lineWidth = 1.4;
      g.beginPath();
      s.values.forEach((v, k) => {
        const x = this.x(this.times[k]), y = this.y(v);
        if (k === 0) g.moveTo(x, y); else g.lineTo(x, y);
      });
      g.stroke();
    }
    this.background = g.getImageData(0, 0, this.canvas.width, this.canvas.height);
  }

  /** Redraws the cursor at time `t`. */
  cursor(t) {
    const g = this.context;
    g.putImageData(this.background, 0, 0);
    const x = this.x(t);
    g.strokeStyle = '#000';
    g.lineWidth = 1;
    g.beginPath(); g.moveTo(x, this.plot.top); g.lineTo(x, this.plot.bottom); g.stroke();
  }
}
