// The look the viewer shares with `weft render` (docs/render.md, "One look"): the colour maps,
// the surfaces' colours and the shading's constants of src/render/appearance.json, which the
// page's bundle holds and which weft compiles into src/render/appearance.cpp. The functions
// here mirror that file's C++ ones; tests/render/test_appearance.cpp runs them in node
// (viewer/test/appearance_dump.mjs) and compares their output with weft's.

/** Linear RGB, 0..1, of an sRGB byte (0..255, not necessarily whole). */
export function srgbDecode(byte) {
  const c = byte / 255;
  return c <= 0.04045 ? c / 12.92 : Math.pow((c + 0.055) / 1.055, 2.4);
}

/** An sRGB byte (0..255) of a linear RGB value in [0, 1], for CSS. */
export function srgbEncodeByte(linear) {
  const c = Math.min(1, Math.max(0, linear));
  return Math.round(255 * (c <= 0.0031308 ? 12.92 * c : 1.055 * Math.pow(c, 1 / 2.4) - 0.055));
}

// `t` in [0, 1] along evenly spaced sRGB stops, interpolated in sRGB and decoded to linear.
function ramp(stops, t, out) {
  const x = Math.min(1, Math.max(0, t)) * (stops.length - 1);
  const k = Math.min(stops.length - 2, Math.floor(x)), a = x - k;
  for (let c = 0; c < 3; ++c) out[c] = srgbDecode(stops[k][c] * (1 - a) + stops[k + 1][c] * a);
  return out;
}

/**
 * The look of `table` (the parsed appearance.json): colour maps that write linear RGB into
 * `out` (3 numbers) and return it, the surfaces' colours (linear RGB), the shading's constants,
 * and the strain map's scale.
 */
export function makeAppearance(table) {
  const maps = table.colour_maps;
  const linear = (srgb) => srgb.map(srgbDecode);
  return {
    /** Added viscosity: `s` in [0, 1] (0 to the run's largest), clamped; NaN as 0. */
    sequential: (s, out) => ramp(maps.sequential.stops_srgb, Number.isNaN(s) ? 0 : s, out),
    /** Strain: `s` in [-1, 1] (minus to plus the scale), clamped; NaN as 0. */
    diverging: (s, out) => ramp(maps.diverging.stops_srgb, Number.isNaN(s) ? 0.5 : 0.5 * (s + 1), out),
    clothFront: linear(table.colours_srgb.cloth_front),
    clothBack: linear(table.colours_srgb.cloth_back),
    collider: linear(table.colours_srgb.collider),
    shading: table.shading,
    /**
     * The strain map's scale: the `percentile` of |values| over at most `max_samples` of them,
     * every floor(n / max_samples)-th from the first; 0 for none.
     */
    strainScale(values) {
      const {percentile, max_samples: maxSamples} = maps.strain_scale;
      const step = Math.max(1, Math.floor(values.length / maxSamples));
      const sample = [];
      for (let k = 0; k < values.length; k += step) sample.push(Math.abs(values[k]));
      if (!sample.length) return 0;
      sample.sort((a, b) => a - b);
      return sample[Math.min(sample.length - 1, Math.floor(percentile / 100 * sample.length))];
    },
  };
}
