//! The rapier world: a fixed base and one dynamic body (plate + payload) made of two colliders,
//! and, with a suspended payload ([`crate::suspension`]), a second dynamic body: the sprung body,
//! whose frame coincides with P when it rests on the plate.
//!
//! The body's frame *is* P: the colliders sit at the body origin, so rapier's local centre of
//! mass and local inertia are in P. Each collider carries its own explicit mass properties
//! (mass, centre of mass, principal moments and principal frame from the full tensor), and rapier
//! sums them into the body's; removing the payload collider leaves the tare world. Colliders
//! belong to no collision group and are sensors: nothing collides, the legs are force elements.
//!
//! Rapier integrates a free body by symplectic Euler: `v ← v + h M⁻¹ F(x)` (then, if enabled,
//! its explicit, momentum-preserving gyroscopic correction), then `x ← x ⊕ h v`. One rapier step per substep
//! (`num_solver_iterations = 1`), so the force we apply at the pose of the step's start is the
//! one integrated. Read as leapfrog, positions belong to the step boundaries and the stored
//! velocities to half a step *before* them; `simulator` uses that to time the sensors.

use nalgebra::{Matrix3, Quaternion, Rotation3, UnitQuaternion, Vector3};
use rapier3d_f64::glamx::{DQuat, DVec3};
use rapier3d_f64::prelude::{
    ColliderBuilder, ColliderHandle, InteractionGroups, MassProperties, PhysicsWorld,
    RigidBodyBuilder, RigidBodyHandle,
};

use crate::body::{principal_axes, BodyProperties};
use kinematics::Pose;

/// Gravity in the base frame B (z up), (0, 0, −9.80665) m/s²: the shared
/// `stewart_types::GRAVITY_B_M_S2`, kept under this name for existing callers.
pub use stewart_types::GRAVITY_B_M_S2 as GRAVITY_M_S2;

pub(crate) fn to_glam(v: &Vector3<f64>) -> DVec3 {
    DVec3::new(v.x, v.y, v.z)
}

pub(crate) fn from_glam(v: DVec3) -> Vector3<f64> {
    Vector3::new(v.x, v.y, v.z)
}

fn rotation_to_glam(r: &Rotation3<f64>) -> DQuat {
    let q = UnitQuaternion::from_rotation_matrix(r);
    DQuat::from_xyzw(q.i, q.j, q.k, q.w).normalize()
}

fn rotation_from_glam(q: DQuat) -> Rotation3<f64> {
    UnitQuaternion::from_quaternion(Quaternion::new(q.w, q.x, q.y, q.z)).to_rotation_matrix()
}

/// Rapier mass properties of a body given in P: explicit mass, centre of mass, principal
/// moments and the principal frame of the full tensor.
pub(crate) fn mass_properties(body: &BodyProperties) -> MassProperties {
    let (moments, axes) = principal_axes(&body.inertia_com());
    MassProperties::with_principal_inertia_frame(
        to_glam(&body.com()),
        body.mass_kg,
        to_glam(&moments),
        rotation_to_glam(&axes),
    )
}

/// What one body is pushed with over a step: forces at points (in groups) and a pure torque,
/// all in B.
pub(crate) struct Loads<'a> {
    pub forces: &'a [&'a [(Vector3<f64>, Vector3<f64>)]],
    pub torque: Vector3<f64>,
}

/// The rapier side of the simulator.
pub(crate) struct PlateWorld {
    world: PhysicsWorld,
    plate: RigidBodyHandle,
    payload: Option<ColliderHandle>,
    /// The sprung body, when the payload rides on a suspension.
    sprung: Option<RigidBodyHandle>,
    rapier_gyroscopic: bool,
}

fn collider(body: &BodyProperties) -> ColliderBuilder {
    ColliderBuilder::ball(0.05)
        .mass_properties(mass_properties(body))
        .sensor(true)
        .collision_groups(InteractionGroups::none())
        .solver_groups(InteractionGroups::none())
}

impl PlateWorld {
    /// A world at `pose`, at rest, stepping by `substep_s`.
    pub fn new(
        fixture: &BodyProperties,
        payload: Option<&BodyProperties>,
        pose: &Pose,
        substep_s: f64,
        rapier_gyroscopic: bool,
    ) -> Self {
        let mut world = PhysicsWorld::new();
        world.gravity = to_glam(&GRAVITY_M_S2);
        world.integration_parameters.dt = substep_s;
        world.integration_parameters.num_solver_iterations = 1;
        // No CCD: nothing collides.
        world.integration_parameters.max_ccd_substeps = 0;
        world.insert_body(RigidBodyBuilder::fixed());
        let plate = world.insert_body(
            RigidBodyBuilder::dynamic()
                .can_sleep(false)
                .gyroscopic_forces_enabled(rapier_gyroscopic)
                .allow_fast_rotation(true)
                .ccd_enabled(false),
        );
        world.insert_collider(collider(fixture), Some(plate));
        let mut w = Self {
            world,
            plate,
            payload: None,
            sprung: None,
            rapier_gyroscopic,
        };
        w.set_payload(payload);
        w.set_state(pose, &Vector3::zeros(), &Vector3::zeros());
        w
    }

    /// Puts the payload collider on the plate (or takes it off).
    pub fn set_payload(&mut self, payload: Option<&BodyProperties>) {
        if let Some(h) = self.payload.take() {
            self.world.remove_collider(h);
        }
        if let Some(p) = payload {
            self.payload = Some(self.world.insert_collider(collider(p), Some(self.plate)));
        }
        // Rapier sums collider mass properties lazily; make them current now.
        let w = &mut self.world;
        if let Some(rb) = w.bodies.get_mut(self.plate) {
            rb.recompute_mass_properties_from_colliders(&w.colliders);
        }
    }

    /// Puts the sprung body in the world (or takes it out), resting on the plate: its frame at
    /// P, moving with the plate.
    pub fn set_sprung(&mut self, body: Option<&BodyProperties>) {
        if let Some(h) = self.sprung.take() {
            self.world.remove_body(h);
        }
        let Some(b) = body else {
            return;
        };
        let handle = self.world.insert_body(
            RigidBodyBuilder::dynamic()
                .can_sleep(false)
                .gyroscopic_forces_enabled(self.rapier_gyroscopic)
                .allow_fast_rotation(true)
                .ccd_enabled(false),
        );
        self.world.insert_collider(collider(b), Some(handle));
        let w = &mut self.world;
        if let Some(rb) = w.bodies.get_mut(handle) {
            rb.recompute_mass_properties_from_colliders(&w.colliders);
        }
        self.sprung = Some(handle);
        let (v_com, omega) = self.raw_velocities();
        let pose = self.pose();
        let com_b = pose.rotation * self.plate_com();
        self.place(handle, &pose, &(v_com - omega.cross(&com_b)), &omega);
    }

    fn plate_com(&self) -> Vector3<f64> {
        self.world
            .bodies
            .get(self.plate)
            .map_or(Vector3::zeros(), |rb| from_glam(rb.local_center_of_mass()))
    }

    /// Teleports the plate, and the sprung body resting on it: pose of P, velocity of the P
    /// origin (in B) and angular velocity (in B).
    pub fn set_state(&mut self, pose: &Pose, v_origin: &Vector3<f64>, omega: &Vector3<f64>) {
        self.place(self.plate, pose, v_origin, omega);
        if let Some(h) = self.sprung {
            self.place(h, pose, v_origin, omega);
        }
    }

    /// Teleports the plate alone.
    #[cfg(test)]
    pub fn set_plate_state(&mut self, pose: &Pose, v_origin: &Vector3<f64>, omega: &Vector3<f64>) {
        self.place(self.plate, pose, v_origin, omega);
    }

    /// Teleports the sprung body alone (its frame's pose, velocity of its origin and angular
    /// velocity, in B).
    #[cfg(test)]
    pub fn set_sprung_state(&mut self, pose: &Pose, v_origin: &Vector3<f64>, omega: &Vector3<f64>) {
        if let Some(h) = self.sprung {
            self.place(h, pose, v_origin, omega);
        }
    }

    fn place(
        &mut self,
        handle: RigidBodyHandle,
        pose: &Pose,
        v_origin: &Vector3<f64>,
        omega: &Vector3<f64>,
    ) {
        let Some(rb) = self.world.bodies.get_mut(handle) else {
            return;
        };
        let com_b = pose.rotation * from_glam(rb.local_center_of_mass());
        rb.set_translation(to_glam(&pose.position_m), true);
        rb.set_rotation(rotation_to_glam(&pose.rotation), true);
        // Rapier's linear velocity is the centre of mass's: v_C = v_O + ω × (R c).
        rb.set_linvel(to_glam(&(v_origin + omega.cross(&com_b))), true);
        rb.set_angvel(to_glam(omega), true);
    }

    /// Pose of P in B.
    pub fn pose(&self) -> Pose {
        self.pose_of(self.plate)
    }

    fn pose_of(&self, handle: RigidBodyHandle) -> Pose {
        match self.world.bodies.get(handle) {
            Some(rb) => Pose::new(
                from_glam(rb.translation()),
                rotation_from_glam(*rb.rotation()),
            ),
            None => Pose::identity(),
        }
    }

    /// The sprung body's pose and rapier's stored velocities (of its centre of mass and
    /// angular, in B), if there is one.
    pub fn sprung_state(&self) -> Option<(Pose, Vector3<f64>, Vector3<f64>)> {
        let h = self.sprung?;
        let rb = self.world.bodies.get(h)?;
        Some((
            self.pose_of(h),
            from_glam(rb.linvel()),
            from_glam(rb.angvel()),
        ))
    }

    /// Rapier's stored velocities: of the centre of mass and angular, both in B.
    pub fn raw_velocities(&self) -> (Vector3<f64>, Vector3<f64>) {
        match self.world.bodies.get(self.plate) {
            Some(rb) => (from_glam(rb.linvel()), from_glam(rb.angvel())),
            None => (Vector3::zeros(), Vector3::zeros()),
        }
    }

    /// Rapier's view of the body: mass, local centre of mass and local inertia about it (P).
    pub fn body_mass_properties(&self) -> (f64, Vector3<f64>, Matrix3<f64>) {
        match self.world.bodies.get(self.plate) {
            Some(rb) => {
                let mp = rb.mass_properties().local_mprops;
                let j = mp.reconstruct_inertia_matrix();
                let cols = j.to_cols_array_2d();
                (
                    mp.mass(),
                    from_glam(mp.local_com),
                    Matrix3::from_fn(|r, c| cols[c][r]),
                )
            }
            None => (0.0, Vector3::zeros(), Matrix3::zeros()),
        }
    }

    /// One physics step with the given forces (in B) acting at the given points (in B) and a
    /// pure torque (in B) on the plate, and the loads of the sprung body (forces at points and
    /// a torque, in B); forces and torques are reset first, so nothing carries over.
    pub fn step(&mut self, plate: &Loads<'_>, sprung: &Loads<'_>) {
        for (handle, loads) in [(Some(self.plate), plate), (self.sprung, sprung)] {
            let Some(rb) = handle.and_then(|h| self.world.bodies.get_mut(h)) else {
                continue;
            };
            rb.reset_forces(false);
            rb.reset_torques(false);
            rb.add_torque(to_glam(&loads.torque), false);
            for part in loads.forces {
                for (force, point) in *part {
                    rb.add_force_at_point(to_glam(force), to_glam(point), false);
                }
            }
        }
        self.world.step();
    }
}
