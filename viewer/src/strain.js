// Strain of a cloth frame against its rest shape: the texture coordinates that weft writes are
// the pattern coordinates divided by the run's uv_scale (metres per texture unit, 1 on a grid
// cloth), so the map from a triangle's texture coordinates times uv_scale to its positions is
// its deformation gradient F (3 x 2), and the largest principal stretch is the square root of
// the largest eigenvalue of C = F^T F. The same as render::vertex_strain (src/render/appearance.hpp),
// which `weft render` uses; tests/render/test_appearance.cpp compares the two.

/**
 * Per vertex, the mean over its triangles of (largest principal stretch - 1), weighted by their
 * areas in texture space. positions: 3 per vertex; texcoords: 2 per vertex; indices: 3 per
 * triangle; uvScale: metres per texture unit; out: 1 per vertex. Triangles of texture-space
 * area (times uvScale^2) 1e-14 or less are left out; a vertex with none gets 0.
 */
export function strainField(positions, texcoords, indices, uvScale, out) {
  const n = out.length;
  const weight = new Float64Array(n);
  out.fill(0);
  for (let t = 0; t < indices.length; t += 3) {
    const i = indices[t], j = indices[t + 1], k = indices[t + 2];
    const du1 = uvScale * (texcoords[2 * j] - texcoords[2 * i]), dv1 = uvScale * (texcoords[2 * j + 1] - texcoords[2 * i + 1]);
    const du2 = uvScale * (texcoords[2 * k] - texcoords[2 * i]), dv2 = uvScale * (texcoords[2 * k + 1] - texcoords[2 * i + 1]);
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
