// Terrain colouring by material (the scene's `terrain_material` and `material_names`,
// docs/http-api.md "The scene format"). No DOM: typed arrays in, typed arrays and plain objects out.

// A qualitative palette that colour-blind readers can tell apart: Okabe & Ito (2008), "Color
// Universal Design (CUD): how to make figures and presentations that are friendly to colorblind
// people", https://jfly.uni-koeln.de/color/ (their eight colours, sRGB). Their black comes last,
// since the hazardous-area contour is drawn black over the terrain; a neutral grey (#999999, not
// one of theirs) comes before it.
export const MATERIAL_PALETTE = [
  [230, 159, 0],    // orange          #E69F00
  [86, 180, 233],   // sky blue        #56B4E9
  [0, 158, 115],    // bluish green    #009E73
  [240, 228, 66],   // yellow          #F0E442
  [0, 114, 178],    // blue            #0072B2
  [213, 94, 0],     // vermillion      #D55E00
  [204, 121, 167],  // reddish purple  #CC79A7
  [153, 153, 153],  // grey            #999999
  [0, 0, 0],        // black           #000000
];

// The materials the terrain uses, in index order (the order of material_names), each with its
// palette colour (palette entry k for the k-th used material, repeating after the palette's
// length) and its number of triangles: [{index, name, color: [r, g, b], triangles}].
// `terrainMaterial` (per triangle, an index into `names`) may be null (an old results file).
export function materialEntries(names, terrainMaterial) {
  if (!terrainMaterial || !names) return [];
  const counts = new Map();
  for (let t = 0; t < terrainMaterial.length; t++) {
    const k = terrainMaterial[t];
    counts.set(k, (counts.get(k) || 0) + 1);
  }
  return [...counts.keys()].sort((a, b) => a - b).map((index, i) => ({
    index,
    name: index < names.length ? names[index] : `material ${index}`,
    color: MATERIAL_PALETTE[i % MATERIAL_PALETTE.length],
    triangles: counts.get(index),
  }));
}

// Per-triangle colours (Uint8Array, 3 per triangle) from materialEntries()'s colours.
export function materialColors(terrainMaterial, entries) {
  const rgb = new Map(entries.map((e) => [e.index, e.color]));
  const m = terrainMaterial.length, out = new Uint8Array(3 * m);
  for (let t = 0; t < m; t++) out.set(rgb.get(terrainMaterial[t]) || [0, 0, 0], 3 * t);
  return out;
}

// The colouring a page opens with. 'job': the PTN density; 'site': the material when the
// terrain uses more than one, else the elevation.
export function defaultColouring(page, entries) {
  if (page === 'job') return 'density';
  return entries.length > 1 ? 'material' : 'elevation';
}

// Can the scene be coloured by material (it carries terrain_material: a results.h5 of format
// 4 or later, or any site)?
export function hasMaterials(scene) {
  return Boolean(scene.arrays.terrain_material && scene.materialNames.length);
}
