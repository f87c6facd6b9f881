// The parts of three.js the report page uses, bundled by
// scripts/install_web_deps.sh (esbuild, IIFE) into web/vendor/three.bundle.min.js,
// which defines the global MG3. The page's own script is web/report_viewer.js.
export {
  AmbientLight, BufferAttribute, BufferGeometry, Color, DataTexture,
  DirectionalLight, DoubleSide, Float32BufferAttribute, LineBasicMaterial,
  LineSegments, Mesh, MeshLambertMaterial, NearestFilter, PerspectiveCamera,
  Raycaster, RGBAFormat, Scene, SRGBColorSpace, Vector2, Vector3,
  WebGLRenderer, REVISION,
} from 'three';
export { OrbitControls } from 'three/addons/controls/OrbitControls.js';
