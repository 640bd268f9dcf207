// One robot of the cell in the 3D view: its URDF posed from live joint values, standing on
// its base in the world where the motion service places it (the base link on the stored
// frame), drawn faint and grey while another robot is in focus.

import * as THREE from "three";
import URDFLoader, { type URDFRobot } from "urdf-loader";
import type { PoseJson } from "./scene";

export interface RobotSource {
  urdf: string;
  packages: Record<string, string>;
  baseLink: string;
  flangeLink: string;
}

/** What the view draws of a robot (world frame, metres): for tests and diagnostics. */
export interface DrawnRobotReport {
  name: string;
  base: number[]; // the base link's origin
  flange: number[]; // the flange link's origin
  dimmed: boolean; // every one of its meshes drawn faint
}

const DIM_OPACITY = 0.3;
const DIM_GREY = new THREE.Color(0x8a94a6);

export function matrixOf(pose: PoseJson): THREE.Matrix4 {
  const [x, y, z, w] = pose.orientation;
  return new THREE.Matrix4().compose(
    new THREE.Vector3(...pose.position),
    new THREE.Quaternion(x, y, z, w),
    new THREE.Vector3(1, 1, 1),
  );
}

function materialsOf(mesh: THREE.Mesh): THREE.Material[] {
  return Array.isArray(mesh.material) ? mesh.material : [mesh.material];
}

export function disposeMaterial(material: THREE.Material): void {
  for (const value of Object.values(material)) {
    if (value instanceof THREE.Texture) value.dispose();
  }
  material.dispose();
}

/** The link's pose relative to the robot's own origin (the URDF's root link). */
function inRobot(link: THREE.Object3D, robot: THREE.Object3D): THREE.Matrix4 {
  const pose = new THREE.Matrix4();
  for (let part: THREE.Object3D | null = link; part && part !== robot; part = part.parent) {
    part.updateMatrix();
    pose.premultiply(part.matrix);
  }
  robot.updateMatrix();
  return pose.premultiply(robot.matrix);
}

export class CellRobot {
  /** Placed in the world: base × (base link in the robot)⁻¹; the URDF hangs below it. */
  readonly mount = new THREE.Group();
  /** Its size stretched out (as URDFs load), for framing the view around it. */
  readonly reach: number;
  private base = new THREE.Matrix4(); // the base link's pose in the world
  private dimmed = false;
  private readonly own = new Map<THREE.Mesh, THREE.Material | THREE.Material[]>();
  private readonly faint = new Map<THREE.Material, THREE.Material>();

  private constructor(
    readonly name: string,
    readonly urdf: string,
    private readonly robot: URDFRobot,
    private readonly baseLink: THREE.Object3D,
    private readonly flange: THREE.Object3D | null,
  ) {
    robot.updateMatrixWorld(true);
    const box = new THREE.Box3().setFromObject(robot);
    this.reach = box.isEmpty() ? 0.3 : Math.max(...box.getSize(new THREE.Vector3()).toArray(), 0.3);
    robot.traverse((part) => {
      if (part instanceof THREE.Mesh) this.own.set(part, part.material);
    });
    this.mount.name = name;
    this.mount.matrixAutoUpdate = false;
    this.mount.add(robot);
    this.place();
  }

  /** Loads the URDF and its meshes; `simple` draws the collision meshes in plain grey. */
  static async load(name: string, source: RobotSource, simple: boolean,
                    progress: (loaded: number, total: number) => void): Promise<CellRobot> {
    const manager = new THREE.LoadingManager();
    manager.onProgress = (_url, loaded, total) => progress(loaded, total);
    const done = new Promise<void>((resolve) => (manager.onLoad = () => resolve()));
    const loader = new URDFLoader(manager);
    loader.packages = source.packages;
    loader.parseVisual = !simple;
    loader.parseCollision = simple;
    const robot = await loader.loadAsync(source.urdf);
    await done; // the meshes
    if (simple) {
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
    const base = robot.links[source.baseLink] ?? robot;
    return new CellRobot(name, source.urdf, robot, base, robot.links[source.flangeLink] ?? null);
  }

  /** The base link's pose in the world, where the mount puts it. */
  get basePose(): THREE.Matrix4 {
    return this.base;
  }

  /** Where its base stands in the world (null: at the origin). */
  setBase(pose: PoseJson | null): void {
    this.base = pose ? matrixOf(pose) : new THREE.Matrix4();
    this.place();
  }

  setJoints(names: string[], values: number[]): void {
    names.forEach((name, i) => this.robot.setJointValue(name, values[i]));
    this.place(); // in case a joint sits between the URDF's root and the base link
  }

  private place(): void {
    this.mount.matrix.copy(this.base).multiply(inRobot(this.baseLink, this.robot).invert());
    this.mount.matrixWorldNeedsUpdate = true;
  }

  /** Faint and grey (another robot is in focus), or as its URDF draws it. */
  setDimmed(dimmed: boolean): void {
    if (dimmed === this.dimmed) return;
    this.dimmed = dimmed;
    for (const [mesh, material] of this.own) {
      if (!dimmed) mesh.material = material;
      else if (Array.isArray(material)) mesh.material = material.map((m) => this.faintOf(m));
      else mesh.material = this.faintOf(material);
    }
  }

  /** One faint copy per material, kept while the robot is drawn: focus changes cost nothing. */
  private faintOf(material: THREE.Material): THREE.Material {
    let faint = this.faint.get(material);
    if (!faint) {
      faint = material.clone();
      faint.transparent = true;
      faint.opacity = material.opacity * DIM_OPACITY;
      faint.depthWrite = false;
      const color = (faint as THREE.Material & { color?: unknown }).color;
      if (color instanceof THREE.Color) color.lerp(DIM_GREY, 0.6);
      this.faint.set(material, faint);
    }
    return faint;
  }

  report(): DrawnRobotReport {
    this.mount.updateMatrixWorld(true);
    const origin = (o: THREE.Object3D) =>
      new THREE.Vector3().setFromMatrixPosition(o.matrixWorld).toArray();
    const meshes = [...this.own.keys()];
    const faint = new Set(this.faint.values());
    return {
      name: this.name,
      base: origin(this.baseLink),
      flange: this.flange ? origin(this.flange) : [],
      dimmed: meshes.length > 0
        && meshes.every((mesh) => materialsOf(mesh).every((m) => faint.has(m))),
    };
  }

  /** Frees its geometries, materials and textures (the GPU's copies with them). */
  dispose(): void {
    this.mount.removeFromParent();
    const materials = new Set<THREE.Material>();
    for (const [mesh, material] of this.own) {
      mesh.geometry.dispose();
      for (const m of Array.isArray(material) ? material : [material]) materials.add(m);
    }
    for (const material of materials) disposeMaterial(material);
    for (const faint of this.faint.values()) faint.dispose(); // its textures are its original's
    this.own.clear();
    this.faint.clear();
  }
}
