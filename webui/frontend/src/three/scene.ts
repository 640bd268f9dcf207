// The robots of the cell in 3D, each its URDF with meshes, posed from live joint values and
// standing where the motion service places it; the one in focus as its URDF draws it, the
// others faint. Waypoint markers and a simulated cell's parts are the focused robot's; the
// scene's objects and a path preview are in the world. Rendered only when something
// changed, to spare a tablet's battery.

import * as THREE from "three";
import { OrbitControls } from "three/examples/jsm/controls/OrbitControls.js";
import { holding, onHeldChange } from "../activity";
import {
  CellRobot,
  type DrawnRobotReport,
  disposeMaterial,
  matrixOf,
  type RobotSource,
} from "./cell-robot";

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
    if (part instanceof THREE.Mesh || part instanceof THREE.Line) {
      part.geometry.dispose();
      for (const m of [part.material].flat() as THREE.Material[]) disposeMaterial(m);
    } else if (part instanceof THREE.Sprite) {
      disposeMaterial(part.material);
    }
  });
}

export interface Marker {
  name: string;
  position: number[]; // x, y, z in the robot's base frame, metres
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
  points: number[][]; // x, y, z
  ok: boolean;
  collision: [number, number, number] | null;
}

/** What the scene holds besides the robots, in the world frame. */
export interface WorldContents {
  obstacles: Obstacle[];
  path: PathPreview | null;
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

export type { DrawnRobotReport, RobotSource };

const GRID_TURN = new THREE.Matrix4().makeRotationX(Math.PI / 2); // three's grids lie in x-z

export class RobotScene {
  private renderer: THREE.WebGLRenderer;
  private scene = new THREE.Scene();
  private camera = new THREE.PerspectiveCamera(45, 1, 0.01, 50);
  private controls: OrbitControls;
  private robots = new Map<string, CellRobot>();
  private loading = new Map<string, number>(); // robot → the round of its latest load
  private loads = 0;
  private bases = new Map<string, PoseJson | null>();
  private focused = "";
  private disposed = false;
  private grid = new THREE.GridHelper(2, 20, 0x3a4a5c, 0x222d3a); // under the focused robot
  private markers = new THREE.Group(); // in the focused robot's base frame
  private parts = new THREE.Group(); // likewise
  private world = new THREE.Group(); // the world frame
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
    for (const group of [this.grid, this.markers, this.parts]) group.matrixAutoUpdate = false;
    this.scene.add(this.grid, this.markers, this.world, this.parts);
    this.placeFocused();
    this.resize();
  }

  /** Draws a robot, or draws it anew if its URDF changed. False when it was removed, or
   * asked for again, before its meshes came. */
  async addRobot(name: string, source: RobotSource, progress: Progress): Promise<boolean> {
    if (this.robots.get(name)?.urdf === source.urdf && !this.loading.has(name)) return true;
    const round = ++this.loads;
    this.loading.set(name, round);
    let robot: CellRobot;
    try {
      robot = await CellRobot.load(name, source, this.software, progress);
    } catch (err) {
      if (this.loading.get(name) === round) this.loading.delete(name);
      throw err;
    }
    if (this.disposed || this.loading.get(name) !== round) {
      robot.dispose();
      return false;
    }
    this.loading.delete(name);
    this.robots.get(name)?.dispose();
    this.robots.set(name, robot);
    robot.setBase(this.bases.get(name) ?? null);
    robot.setDimmed(name !== this.focused);
    this.scene.add(robot.mount);
    if (name === this.focused) {
      this.placeFocused();
      this.frameFocused();
    }
    this.requestRender();
    return true;
  }

  removeRobot(name: string): void {
    this.loading.delete(name);
    this.robots.get(name)?.dispose();
    this.robots.delete(name);
    this.bases.delete(name);
    if (name === this.focused) this.placeFocused();
    this.requestRender();
  }

  /** The robot drawn as it is; every other one faint. The view turns to it. */
  setFocus(name: string): void {
    if (name === this.focused) return;
    this.focused = name;
    for (const [other, robot] of this.robots) robot.setDimmed(other !== name);
    this.placeFocused();
    this.frameFocused();
    this.requestRender();
  }

  /** Where a robot's base stands in the world (null: the origin). */
  setBase(name: string, pose: PoseJson | null): void {
    this.bases.set(name, pose);
    const robot = this.robots.get(name);
    if (!robot) return;
    const before = robot.basePose.clone();
    robot.setBase(pose);
    if (name === this.focused) {
      // The view goes with it, as it is turned now.
      const moved = robot.basePose.clone().multiply(before.invert());
      const c = this.controls;
      for (const point of [this.camera.position, c.target, c.position0, c.target0]) {
        point.applyMatrix4(moved);
      }
      c.update();
      this.placeFocused();
    }
    this.requestRender();
  }

  setJoints(name: string, joints: string[], values: number[]): void {
    const robot = this.robots.get(name);
    if (!robot) return;
    robot.setJoints(joints, values);
    this.requestRender();
  }

  /** What is drawn of each robot, where (world frame), and whether faint. */
  drawn(): DrawnRobotReport[] {
    return [...this.robots.values()].map((robot) => robot.report());
  }

  /** Markers, parts and the grid on the focused robot's base (the world's origin, while
   * none is drawn). */
  private placeFocused(): void {
    const base = this.robots.get(this.focused)?.basePose ?? new THREE.Matrix4();
    for (const group of [this.markers, this.parts]) {
      if (group.matrix.equals(base)) continue;
      group.matrix.copy(base);
      group.matrixWorldNeedsUpdate = true;
    }
    this.grid.matrix.copy(base).multiply(GRID_TURN);
    this.grid.matrixWorldNeedsUpdate = true;
  }

  /** Frame the focused robot by its reach (measured stretched out, as URDFs load), around
   * its base: the view then suits every pose it can take. */
  private frameFocused(): void {
    const robot = this.robots.get(this.focused);
    if (!robot) return;
    const reach = robot.reach;
    const base = robot.basePose;
    this.controls.target.set(0, 0, reach * 0.35).applyMatrix4(base);
    this.camera.position.set(reach * 1.25, -reach * 1.45, reach * 1.0).applyMatrix4(base);
    this.controls.update();
    this.controls.saveState();
  }

  /** Back to the view the robot in focus was first shown in. */
  resetView(): void {
    this.controls.reset();
    this.requestRender();
  }

  setMarkers(markers: Marker[]): void {
    for (const child of [...this.markers.children]) disposeTree(child);
    this.markers.clear();
    for (const m of markers) {
      const color = m.selected ? 0x3fb950 : 0xf5a524;
      const sphere = new THREE.Mesh(
        new THREE.SphereGeometry(m.selected ? 0.022 : 0.014, 16, 12),
        new THREE.MeshStandardMaterial({ color }),
      );
      sphere.position.fromArray(m.position);
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
    this.requestRender();
    return drawn;
  }

  setWorld(contents: WorldContents): void {
    for (const child of [...this.world.children]) disposeTree(child);
    this.world.clear();
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

  resize(): void {
    const width = Math.max(1, this.host.clientWidth);
    const height = Math.max(1, this.host.clientHeight);
    this.renderer.setSize(width, height, false);
    this.camera.aspect = width / height;
    this.camera.updateProjectionMatrix();
    this.requestRender();
  }

  requestRender(): void {
    if (this.frame || this.disposed) return;
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

  /** Frees everything it drew, and its WebGL context (a browser keeps only a few). */
  dispose(): void {
    this.disposed = true;
    cancelAnimationFrame(this.frame);
    window.clearTimeout(this.frame);
    this.unsubscribe();
    this.loading.clear();
    for (const robot of this.robots.values()) robot.dispose();
    this.robots.clear();
    for (const group of [this.markers, this.parts, this.world, this.grid]) disposeTree(group);
    this.controls.dispose();
    this.renderer.dispose();
    this.renderer.forceContextLoss();
    this.renderer.domElement.remove();
  }
}
