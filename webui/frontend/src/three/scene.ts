// The robot in 3D: its URDF with meshes, posed from live joint values, with waypoint markers.
// Rendered only when something changed, to spare a tablet's battery.

import * as THREE from "three";
import { OrbitControls } from "three/examples/jsm/controls/OrbitControls.js";
import URDFLoader, { type URDFRobot } from "urdf-loader";
import { holding, onHeldChange } from "../activity";

export interface Marker {
  name: string;
  position: [number, number, number]; // in the robot's base frame, metres
  selected: boolean;
}

export type Progress = (loaded: number, total: number) => void;

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
    this.controls.target.set(0, 0, 0.35);
    this.controls.addEventListener("change", () => this.requestRender());
    this.scene.add(new THREE.HemisphereLight(0xe8eef5, 0x202830, 2.2));
    const sun = new THREE.DirectionalLight(0xffffff, 1.6);
    sun.position.set(2, -3, 4);
    this.scene.add(sun);
    const grid = new THREE.GridHelper(2, 20, 0x3a4a5c, 0x222d3a);
    grid.rotation.x = Math.PI / 2;
    this.scene.add(grid, this.markers);
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
  }

  setJoints(names: string[], values: number[]): void {
    if (!this.robot) return;
    names.forEach((name, i) => this.robot?.setJointValue(name, values[i]));
    this.requestRender();
  }

  setMarkers(markers: Marker[]): void {
    this.markers.clear();
    if (!this.base) return;
    this.base.updateMatrixWorld(true);
    for (const m of markers) {
      const sphere = new THREE.Mesh(
        new THREE.SphereGeometry(m.selected ? 0.022 : 0.014, 16, 12),
        new THREE.MeshStandardMaterial({ color: m.selected ? 0x3fb950 : 0xf5a524 }),
      );
      sphere.position.set(...m.position).applyMatrix4(this.base.matrixWorld);
      sphere.name = m.name;
      this.markers.add(sphere);
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
