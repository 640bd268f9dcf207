// The robot in 3D: its URDF with meshes, posed from live joint values, with waypoint markers.
// Rendered only when something changed, to spare a tablet's battery.

import * as THREE from "three";
import { OrbitControls } from "three/examples/jsm/controls/OrbitControls.js";
import URDFLoader, { type URDFRobot } from "urdf-loader";
import { holding, onHeldChange } from "../activity";

/** A name drawn beside a marker, always facing the camera and never hidden by the robot. */
function label(text: string, color: number): THREE.Sprite {
  const canvas = document.createElement("canvas");
  const context = canvas.getContext("2d");
  const font = "bold 40px system-ui, sans-serif";
  canvas.height = 56;
  if (context) {
    context.font = font;
    canvas.width = Math.min(1024, Math.ceil(context.measureText(text).width) + 24);
    context.font = font; // resizing the canvas reset it
    context.fillStyle = "rgba(11, 16, 21, 0.8)";
    context.fillRect(0, 0, canvas.width, canvas.height);
    context.fillStyle = `#${color.toString(16).padStart(6, "0")}`;
    context.textBaseline = "middle";
    context.fillText(text, 12, canvas.height / 2);
  }
  const texture = new THREE.CanvasTexture(canvas);
  texture.colorSpace = THREE.SRGBColorSpace;
  const sprite = new THREE.Sprite(new THREE.SpriteMaterial({ map: texture, depthTest: false }));
  const height = 0.035; // m
  sprite.scale.set((height * canvas.width) / canvas.height, height, 1);
  sprite.renderOrder = 1;
  return sprite;
}

function disposeTree(root: THREE.Object3D): void {
  root.traverse((part) => {
    if (part instanceof THREE.Mesh) {
      part.geometry.dispose();
      (part.material as THREE.Material).dispose();
    } else if (part instanceof THREE.Sprite) {
      part.material.map?.dispose();
      part.material.dispose();
    }
  });
}

export interface Marker {
  name: string;
  position: [number, number, number]; // in the robot's base frame, metres
  selected: boolean;
}

/** A part of a simulated cell, where it truly lies (the robot's base frame, metres). */
export interface CellPart {
  id: string;
  size: number[];
  pose: PoseJson;
  held: boolean;
}

export type Progress = (loaded: number, total: number) => void;

export interface PoseJson {
  position: number[];
  orientation: number[]; // quaternion x, y, z, w
}

/** A scene object as stored (world frame, metres); meshes show as their name only. */
export interface Obstacle {
  name: string;
  shape: "box" | "cylinder" | "sphere" | "mesh";
  size: number[];
  pose: PoseJson;
  keep_out: boolean;
  color: string;
  attached_to: string | null;
  selected?: boolean;
}

/** A planned TCP path in the world frame, drawn green when clear and red when it collides. */
export interface PathPreview {
  points: [number, number, number][];
  ok: boolean;
  collision: [number, number, number] | null;
}

export interface WorldContents {
  base: PoseJson | null; // this robot's base in the world
  obstacles: Obstacle[];
  path: PathPreview | null;
}

function matrixOf(pose: PoseJson): THREE.Matrix4 {
  const [x, y, z, w] = pose.orientation;
  return new THREE.Matrix4().compose(
    new THREE.Vector3(...pose.position),
    new THREE.Quaternion(x, y, z, w),
    new THREE.Vector3(1, 1, 1),
  );
}

function obstacleMesh(o: Obstacle): THREE.Object3D | null {
  let geometry: THREE.BufferGeometry;
  if (o.shape === "box") geometry = new THREE.BoxGeometry(o.size[0], o.size[1], o.size[2]);
  else if (o.shape === "cylinder") {
    geometry = new THREE.CylinderGeometry(o.size[0], o.size[0], o.size[1], 32);
    geometry.rotateX(Math.PI / 2); // three's cylinders stand along y; ours along z
  } else if (o.shape === "sphere") geometry = new THREE.SphereGeometry(o.size[0], 24, 16);
  else return null;
  const color = o.selected ? 0xf5a524 : o.keep_out ? 0xf85149 : new THREE.Color(o.color);
  const material = new THREE.MeshPhongMaterial({
    color,
    transparent: true,
    opacity: o.keep_out ? 0.3 : 0.75,
  });
  const mesh = new THREE.Mesh(geometry, material);
  mesh.name = o.name;
  mesh.matrixAutoUpdate = false;
  mesh.matrix.copy(matrixOf(o.pose));
  return mesh;
}

// Without a GPU (WebGL in software) a detailed model at 30 frames/s would take the page's
// whole main thread, and with it the jog heartbeat: draw the simpler collision meshes,
// and fewer frames.
const SOFTWARE_FRAME_MS = 200;

function isSoftware(renderer: THREE.WebGLRenderer): boolean {
  const gl = renderer.getContext();
  const info = gl.getExtension("WEBGL_debug_renderer_info");
  const name = info ? String(gl.getParameter(info.UNMASKED_RENDERER_WEBGL)) : "";
  return /swiftshader|llvmpipe|software/i.test(name);
}

export class RobotScene {
  private renderer: THREE.WebGLRenderer;
  private scene = new THREE.Scene();
  private camera = new THREE.PerspectiveCamera(45, 1, 0.01, 50);
  private controls: OrbitControls;
  private robot: URDFRobot | null = null;
  private base: THREE.Object3D | null = null;
  private markers = new THREE.Group();
  private parts = new THREE.Group(); // in the robot's base frame, placed by its base link
  private world = new THREE.Group(); // world-frame contents, placed by the robot's base
  private worldBase: PoseJson | null = null;
  private frame = 0;
  private lastFrame = 0;
  private unsubscribe: () => void;
  readonly software: boolean;

  constructor(private host: HTMLElement) {
    this.renderer = new THREE.WebGLRenderer({ antialias: true, alpha: false });
    this.renderer.setPixelRatio(Math.min(window.devicePixelRatio, 2));
    this.renderer.setClearColor(0x0b1015);
    host.appendChild(this.renderer.domElement);
    this.software = isSoftware(this.renderer);
    if (this.software) this.renderer.setPixelRatio(1);
    this.unsubscribe = onHeldChange(() => this.requestRender());
    this.camera.up.set(0, 0, 1); // URDFs are Z-up
    this.camera.position.set(1.4, -1.2, 1.0);
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    // One finger scrolls the page, as everywhere else on a pendant; two fingers turn and
    // zoom the view (and the mouse still orbits).
    this.controls.touches = { ONE: null, TWO: THREE.TOUCH.DOLLY_ROTATE };
    this.controls.zoomSpeed = 0.4; // a pinch zooms by about what the fingers moved
    this.renderer.domElement.style.touchAction = "pan-y";
    this.controls.target.set(0, 0, 0.35);
    this.controls.addEventListener("change", () => this.requestRender());
    this.scene.add(new THREE.HemisphereLight(0xe8eef5, 0x202830, 2.2));
    const sun = new THREE.DirectionalLight(0xffffff, 1.6);
    sun.position.set(2, -3, 4);
    this.scene.add(sun);
    const grid = new THREE.GridHelper(2, 20, 0x3a4a5c, 0x222d3a);
    grid.rotation.x = Math.PI / 2;
    this.world.matrixAutoUpdate = false;
    this.parts.matrixAutoUpdate = false;
    this.scene.add(grid, this.markers, this.world, this.parts);
    this.resize();
  }

  async load(urdf: string, packages: Record<string, string>, baseLink: string,
             progress: Progress): Promise<void> {
    const manager = new THREE.LoadingManager();
    manager.onProgress = (_url, loaded, total) => progress(loaded, total);
    const done = new Promise<void>((resolve) => (manager.onLoad = () => resolve()));
    const loader = new URDFLoader(manager);
    loader.packages = packages;
    loader.parseVisual = !this.software;
    loader.parseCollision = this.software;
    const robot = await loader.loadAsync(urdf);
    this.robot = robot;
    this.base = robot.links[baseLink] ?? robot;
    this.scene.add(robot);
    await done; // the meshes
    if (this.software) {
      // Collision meshes carry no material of their own, and STL files often carry zeroed
      // normals (which light as black).
      const grey = new THREE.MeshPhongMaterial({ color: 0x9aa3ab });
      robot.traverse((part) => {
        if (part instanceof THREE.Mesh) {
          part.material = grey;
          part.geometry.computeVertexNormals();
        }
      });
    }
    this.frameRobot(robot);
    this.placeWorld();
    this.placeParts();
    this.requestRender();
  }

  /** Frame the robot by its reach (measured stretched out, as URDFs load), around its
   * base: the view then suits every pose it can take. */
  private frameRobot(robot: THREE.Object3D): void {
    robot.updateMatrixWorld(true);
    const box = new THREE.Box3().setFromObject(robot);
    if (box.isEmpty()) return;
    const reach = Math.max(...box.getSize(new THREE.Vector3()).toArray(), 0.3);
    this.controls.target.set(0, 0, reach * 0.35);
    this.camera.position.set(reach * 1.25, -reach * 1.45, reach * 1.0);
    this.controls.update();
    this.controls.saveState();
  }

  /** Back to the view the robot was first shown in. */
  resetView(): void {
    this.controls.reset();
    this.requestRender();
  }

  setJoints(names: string[], values: number[]): void {
    if (!this.robot) return;
    names.forEach((name, i) => this.robot?.setJointValue(name, values[i]));
    this.requestRender();
  }

  setMarkers(markers: Marker[]): void {
    for (const child of [...this.markers.children]) disposeTree(child);
    this.markers.clear();
    if (!this.base) return;
    this.base.updateMatrixWorld(true);
    for (const m of markers) {
      const color = m.selected ? 0x3fb950 : 0xf5a524;
      const sphere = new THREE.Mesh(
        new THREE.SphereGeometry(m.selected ? 0.022 : 0.014, 16, 12),
        new THREE.MeshStandardMaterial({ color }),
      );
      sphere.position.set(...m.position).applyMatrix4(this.base.matrixWorld);
      sphere.name = m.name;
      const tag = label(m.name, color);
      tag.position.set(0, 0, 0.045);
      sphere.add(tag);
      this.markers.add(sphere);
    }
    this.requestRender();
  }

  /** The cell's parts as boxes (a held one lit up); what is drawn, by id and position. */
  setParts(parts: CellPart[]): string[] {
    for (const child of [...this.parts.children]) disposeTree(child);
    this.parts.clear();
    const drawn: string[] = [];
    for (const p of parts) {
      const [x, y, z] = p.size;
      const box = new THREE.Mesh(
        new THREE.BoxGeometry(x, y, z),
        new THREE.MeshPhongMaterial({ color: p.held ? 0x3fb950 : 0xc8a165 }),
      );
      box.name = p.id;
      box.matrixAutoUpdate = false;
      box.matrix.copy(matrixOf(p.pose));
      this.parts.add(box);
      drawn.push(`${p.id}@${p.pose.position.map((v) => v.toFixed(3)).join(",")}`);
    }
    this.placeParts();
    this.requestRender();
    return drawn;
  }

  private placeParts(): void {
    if (!this.base) return;
    this.base.updateMatrixWorld(true);
    this.parts.matrix.copy(this.base.matrixWorld);
    this.parts.matrixWorldNeedsUpdate = true;
  }

  setWorld(contents: WorldContents): void {
    for (const child of [...this.world.children]) {
      this.world.remove(child);
      child.traverse((part) => {
        if (part instanceof THREE.Mesh || part instanceof THREE.Line) part.geometry.dispose();
      });
    }
    this.worldBase = contents.base;
    this.placeWorld();
    for (const o of contents.obstacles) {
      const mesh = o.attached_to ? null : obstacleMesh(o);
      if (mesh) this.world.add(mesh);
    }
    const path = contents.path;
    if (path && path.points.length > 1) {
      const line = new THREE.Line(
        new THREE.BufferGeometry().setFromPoints(path.points.map((p) => new THREE.Vector3(...p))),
        new THREE.LineBasicMaterial({ color: path.ok ? 0x3fb950 : 0xf85149 }),
      );
      line.name = "path";
      this.world.add(line);
    }
    if (path?.collision) {
      const hit = new THREE.Mesh(
        new THREE.SphereGeometry(0.02, 16, 12),
        new THREE.MeshBasicMaterial({ color: 0xf85149 }),
      );
      hit.position.set(...path.collision);
      this.world.add(hit);
    }
    this.requestRender();
  }

  /** World coordinates drawn where they are relative to the robot, which stands at the
   * view's origin: base link × (base in the world)⁻¹. */
  private placeWorld(): void {
    const inWorld = this.worldBase ? matrixOf(this.worldBase).invert() : new THREE.Matrix4();
    if (this.base) {
      this.base.updateMatrixWorld(true);
      this.world.matrix.copy(this.base.matrixWorld).multiply(inWorld);
    } else this.world.matrix.copy(inWorld);
    this.world.matrixWorldNeedsUpdate = true;
  }

  resize(): void {
    const width = Math.max(1, this.host.clientWidth);
    const height = Math.max(1, this.host.clientHeight);
    this.renderer.setSize(width, height, false);
    this.camera.aspect = width / height;
    this.camera.updateProjectionMatrix();
    this.requestRender();
  }

  requestRender(): void {
    if (this.frame) return;
    // A software frame can block the page longer than a jog heartbeat may wait.
    if (this.software && holding()) return;
    const wait = this.software ? this.lastFrame + SOFTWARE_FRAME_MS - performance.now() : 0;
    const draw = () => {
      this.frame = requestAnimationFrame(() => {
        this.frame = 0;
        if (this.software && holding()) return; // a press began meanwhile: draw on release
        this.lastFrame = performance.now();
        this.renderer.render(this.scene, this.camera);
      });
    };
    if (wait > 0) this.frame = window.setTimeout(draw, wait);
    else draw();
  }

  dispose(): void {
    cancelAnimationFrame(this.frame);
    window.clearTimeout(this.frame);
    this.unsubscribe();
    this.controls.dispose();
    this.renderer.dispose();
    this.renderer.domElement.remove();
  }
}
