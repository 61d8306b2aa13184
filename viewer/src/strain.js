// Strain of a cloth frame against its rest shape: the texture coordinates that weft writes are
// the pattern coordinates (metres on a grid cloth), so the map from a triangle's texture
// coordinates to its positions is its deformation gradient F (3 x 2), and the largest principal
// stretch is the square root of the largest eigenvalue of C = F^T F.

/**
 * Per vertex, the area-weighted mean over its triangles of (largest principal stretch - 1).
 * positions: 3 per vertex; texcoords: 2 per vertex; indices: 3 per triangle; out: 1 per vertex.
 * Triangles whose texture coordinates have no area are left out.
 */
export function strainField(positions, texcoords, indices, out) {
  const n = out.length;
  const weight = new Float32Array(n);
  out.fill(0);
  for (let t = 0; t < indices.length; t += 3) {
    const i = indices[t], j = indices[t + 1], k = indices[t + 2];
    const du1 = texcoords[2 * j] - texcoords[2 * i], dv1 = texcoords[2 * j + 1] - texcoords[2 * i + 1];
    const du2 = texcoords[2 * k] - texcoords[2 * i], dv2 = texcoords[2 * k + 1] - texcoords[2 * i + 1];
    const det = du1 * dv2 - du2 * dv1;
    const area = 0.5 * Math.abs(det);
    if (!(area > 1e-14)) continue;
    // The inverse of D = [[du1, du2], [dv1, dv2]] (edge vectors in texture space as columns).
    const a00 = dv2 / det, a01 = -du2 / det, a10 = -dv1 / det, a11 = du1 / det;
    let c0 = 0, c01 = 0, c1 = 0;
    for (let d = 0; d < 3; ++d) {
      const e1 = positions[3 * j + d] - positions[3 * i + d], e2 = positions[3 * k + d] - positions[3 * i + d];
      const f0 = e1 * a00 + e2 * a10, f1 = e1 * a01 + e2 * a11;  // F = [e1 e2] D^-1, by rows
      c0 += f0 * f0, c01 += f0 * f1, c1 += f1 * f1;
    }
    const half = 0.5 * (c0 + c1), diff = 0.5 * (c0 - c1);
    const stretch = Math.sqrt(half + Math.sqrt(diff * diff + c01 * c01)) - 1;
    out[i] += area * stretch, out[j] += area * stretch, out[k] += area * stretch;
    weight[i] += area, weight[j] += area, weight[k] += area;
  }
  for (let v = 0; v < n; ++v) out[v] = weight[v] > 0 ? out[v] / weight[v] : 0;
}

/** The 99th percentile of |values| (of at most 200,000 evenly spaced samples): a colour scale that one outlier does not flatten. */
export function symmetricScale(values) {
  const step = Math.max(1, Math.floor(values.length / 200000));
  const sample = [];
  for (let k = 0; k < values.length; k += step) sample.push(Math.abs(values[k]));
  if (!sample.length) return 0;
  sample.sort((a, b) => a - b);
  return sample[Math.min(sample.length - 1, Math.floor(0.99 * sample.length))];
}
