// Writes `foliage.glb`, the textured source scene of the export tests, with
// glTF Transform's own writer (the same library as the gltf-transform CLI):
//
//   node make_foliage.mjs OUT.glb
//
// Metres, Y up, no node transform on the geometry. One directional sun
// (3 W/m², travelling along (−1, −1, 0)/√2), a top-down orthographic camera
// over the 6 m × 6 m floor (image up = −Z, right = +X), and:
//   - Floor (y = 0, x, z ∈ [−3, 3]): a grey checker texture (12 × 12 checks,
//     sRGB 230 / 90) with KHR_texture_transform offset [1/12, 0]: one check
//     to the right, which swaps the colours of the checks;
//   - Wall (x = −3, y ∈ [0, 2], facing +X): KHR_materials_pbrSpecularGlossiness
//     with a red diffuseFactor (0.9, 0.1, 0.1); its metallic-roughness
//     fallback is white, so a reader that ignores the extension sees white;
//   - Fence (x = −2.2, z ∈ [−3, 0], y ∈ [0, 1.6], facing +X): alphaMode MASK,
//     vertical stripes, half of them transparent: the wall's bounce light
//     and the sun reach the floor behind it through the gaps;
//   - Leaf cards (0.8 m squares at y = 1, alphaMode MASK, a checker of
//     opaque and transparent 8-texel squares, open fraction 1/2): LeafA at
//     z = 0.8 and LeafC at z = 2.0 share one mesh (static; gltf-transform
//     `instance` turns them into EXT_mesh_gpu_instancing), LeafB at
//     z = −2.2 has its own copy of the mesh and `extras.dynamic`, a moving
//     object. The sun throws their dappled shadows 1 m towards −X.
// Deterministic: the same bytes on every run.

import { Document, NodeIO } from '@gltf-transform/core';
import {
  KHRLightsPunctual,
  KHRMaterialsPBRSpecularGlossiness,
  KHRTextureTransform,
} from '@gltf-transform/extensions';
import sharp from 'sharp';

const out = process.argv[2];
if (!out) {
  console.error('usage: node make_foliage.mjs OUT.glb');
  process.exit(2);
}

/** An RGBA8 PNG of `size`² texels, `f(x, y)` → [r, g, b, a]. */
async function png(size, f) {
  const raw = Buffer.alloc(size * size * 4);
  for (let y = 0; y < size; y++) {
    for (let x = 0; x < size; x++) {
      raw.set(f(x, y), (y * size + x) * 4);
    }
  }
  return new Uint8Array(
    await sharp(raw, { raw: { width: size, height: size, channels: 4 } })
      .png({ compressionLevel: 9, palette: false })
      .toBuffer(),
  );
}

const doc = new Document();
doc.getRoot().getAsset().generator = 'gibake tools/exports/make_foliage.mjs (glTF Transform)';
const buffer = doc.createBuffer();
const scene = doc.createScene('foliage');
doc.getRoot().setDefaultScene(scene);
const transform = doc.createExtension(KHRTextureTransform);
const specGloss = doc.createExtension(KHRMaterialsPBRSpecularGlossiness);
const lights = doc.createExtension(KHRLightsPunctual);

/** A quad mesh from four corners (counter-clockwise seen from `normal`). */
function quad(name, corners, normal, uvs, material) {
  const acc = (type, array) => doc.createAccessor().setType(type).setArray(array).setBuffer(buffer);
  const prim = doc
    .createPrimitive()
    .setAttribute('POSITION', acc('VEC3', new Float32Array(corners.flat())))
    .setAttribute('NORMAL', acc('VEC3', new Float32Array([normal, normal, normal, normal].flat())))
    .setAttribute('TEXCOORD_0', acc('VEC2', new Float32Array(uvs.flat())))
    .setIndices(acc('SCALAR', new Uint16Array([0, 1, 2, 0, 2, 3])))
    .setMaterial(material);
  return doc.createMesh(name).addPrimitive(prim);
}

function texture(name, image) {
  return doc.createTexture(name).setImage(image).setMimeType('image/png').setURI(`${name}.png`);
}

// Floor: checker, shifted one check by KHR_texture_transform.
const checker = texture(
  'checker',
  await png(96, (x, y) => {
    const v = ((x >> 3) + (y >> 3)) % 2 === 0 ? 230 : 90;
    return [v, v, v, 255];
  }),
);
const floorMat = doc
  .createMaterial('Floor')
  .setBaseColorTexture(checker)
  .setMetallicFactor(0)
  .setRoughnessFactor(1);
floorMat
  .getBaseColorTextureInfo()
  .setExtension('KHR_texture_transform', transform.createTransform().setOffset([1 / 12, 0]));
const floor = quad(
  'Floor',
  [
    [-3, 0, 3],
    [3, 0, 3],
    [3, 0, -3],
    [-3, 0, -3],
  ],
  [0, 1, 0],
  [
    [0, 1],
    [1, 1],
    [1, 0],
    [0, 0],
  ],
  floorMat,
);

// Wall: red through KHR_materials_pbrSpecularGlossiness only.
const wallMat = doc
  .createMaterial('RedWall')
  .setBaseColorFactor([1, 1, 1, 1])
  .setMetallicFactor(0)
  .setRoughnessFactor(1)
  .setExtension(
    'KHR_materials_pbrSpecularGlossiness',
    specGloss
      .createPBRSpecularGlossiness()
      .setDiffuseFactor([0.9, 0.1, 0.1, 1])
      .setSpecularFactor([0, 0, 0])
      .setGlossinessFactor(0),
  );
const wall = quad(
  'Wall',
  [
    [-3, 0, 3],
    [-3, 0, -3],
    [-3, 2, -3],
    [-3, 2, 3],
  ],
  [1, 0, 0],
  [
    [0, 1],
    [1, 1],
    [1, 0],
    [0, 0],
  ],
  wallMat,
);

// Fence: vertical stripes, every other one transparent.
const stripes = texture(
  'stripes',
  await png(64, (x) => ((x >> 3) % 2 === 0 ? [235, 235, 235, 255] : [235, 235, 235, 0])),
);
const fenceMat = doc
  .createMaterial('Fence')
  .setBaseColorTexture(stripes)
  .setAlphaMode('MASK')
  .setAlphaCutoff(0.5)
  .setDoubleSided(true)
  .setMetallicFactor(0)
  .setRoughnessFactor(1);
const fence = quad(
  'Fence',
  [
    [-2.2, 0, 0],
    [-2.2, 0, -3],
    [-2.2, 1.6, -3],
    [-2.2, 1.6, 0],
  ],
  [1, 0, 0],
  [
    [0, 1],
    [1, 1],
    [1, 0],
    [0, 0],
  ],
  fenceMat,
);

// Leaves: a checker of opaque and transparent squares.
const leafTex = texture(
  'leaf',
  await png(64, (x, y) =>
    ((x >> 3) + (y >> 3)) % 2 === 0 ? [70, 150, 60, 255] : [70, 150, 60, 0],
  ),
);
const leafMat = doc
  .createMaterial('Leaf')
  .setBaseColorTexture(leafTex)
  .setAlphaMode('MASK')
  .setAlphaCutoff(0.5)
  .setDoubleSided(true)
  .setMetallicFactor(0)
  .setRoughnessFactor(1);
const leafCorners = [
  [-0.4, 0, 0.4],
  [0.4, 0, 0.4],
  [0.4, 0, -0.4],
  [-0.4, 0, -0.4],
];
const leafUvs = [
  [0, 1],
  [1, 1],
  [1, 0],
  [0, 0],
];
const leaf = quad('Leaf', leafCorners, [0, 1, 0], leafUvs, leafMat);
const leafMoving = quad('LeafMoving', leafCorners, [0, 1, 0], leafUvs, leafMat);

for (const [name, mesh] of [
  ['Floor', floor],
  ['Wall', wall],
  ['Fence', fence],
]) {
  scene.addChild(doc.createNode(name).setMesh(mesh));
}
scene.addChild(doc.createNode('LeafA').setMesh(leaf).setTranslation([1.2, 1, 0.8]));
scene.addChild(doc.createNode('LeafC').setMesh(leaf).setTranslation([1.2, 1, 2.0]));
scene.addChild(
  doc
    .createNode('LeafB')
    .setMesh(leafMoving)
    .setTranslation([1.2, 1, -2.2])
    .setExtras({ dynamic: true }),
);

// The sun: the light looks down its node's −Z; rotate −Z onto (−1, −1, 0)/√2.
const sun = lights.createLight('Sun').setType('directional').setColor([1, 1, 1]).setIntensity(3);
scene.addChild(
  doc
    .createNode('Sun')
    .setTranslation([3, 3, 0])
    .setRotation([-0.5, 0.5, 0, Math.SQRT1_2])
    .setExtension('KHR_lights_punctual', sun),
);

// Top-down orthographic camera: −90° about X.
const camera = doc
  .createCamera('Top')
  .setType('orthographic')
  .setXMag(3)
  .setYMag(3)
  .setZNear(0.1)
  .setZFar(20);
scene.addChild(
  doc
    .createNode('Top')
    .setCamera(camera)
    .setTranslation([0, 6, 0])
    .setRotation([-Math.SQRT1_2, 0, 0, Math.SQRT1_2]),
);

const io = new NodeIO().registerExtensions([
  KHRLightsPunctual,
  KHRMaterialsPBRSpecularGlossiness,
  KHRTextureTransform,
]);
await io.write(out, doc);
console.log(`${out} written`);
