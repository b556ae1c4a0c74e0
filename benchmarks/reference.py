"""An exact reference for the porous material: a small numpy renderer, direct lighting only.

Analytic scenes (a sphere, a plane, a V-groove) are seen by the studio's orthographic camera
(``studio.add_ortho_camera``: looking down -Z, ``ortho_scale`` 2.2), one point per pixel
centre, as Cycles samples them with ``render.use_cycles``' point-sized pixel filter.

The BRDF is evaluated per light direction: model.py's weights at that direction (or at the
directions a light mode of docs/model.md §3 assumes instead), times the lobes Blender renders:
Lambert, and Cycles' single-scatter GGX Glossy BSDF (intern/cycles/kernel/closure/
bsdf_microfacet.h: alpha = roughness^2 saturated to [0, 1], GGX D, height-correlated Smith
G2 = 1 / (1 + Lambda_l + Lambda_v), no Fresnel; a mirror when alpha^2 <= 1e-7).

Lights, in Blender's units: a sun of strength E gives irradiance E; a point light of power P
has intensity P / (4 pi); an area light of power P and area A has radiance P / (pi A),
integrated by an n x n midpoint rule; a world of strength L has radiance L, integrated by
importance-sampled Monte Carlo whose per-pixel 3-sigma error is returned with the image.

No bpy here: it runs in plain Python.
"""

from dataclasses import dataclass

import numpy as np

from porous_weathering.core import model

#: Cycles renders a GGX lobe with alpha^2 at or below this as a perfect mirror.
MIRROR_ALPHA2 = 1e-7

#: The studio camera: looking down -Z from above, so the viewer is along +Z everywhere.
VIEW = np.array([0.0, 0.0, 1.0])
ORTHO_SCALE = 2.2

EXACT, AMBIENT = "EXACT", "AMBIENT"

# --- the lobes ---------------------------------------------------------------------------


def ggx_alpha2(roughness):
    """alpha^2 of a Glossy BSDF of this roughness: alpha = roughness^2, saturated."""
    alpha = np.clip(np.asarray(roughness, dtype=np.float64), 0.0, 1.0) ** 2
    return alpha * alpha


def ggx_d(n_dot_h, alpha2):
    return alpha2 / (np.pi * (1.0 + (alpha2 - 1.0) * n_dot_h * n_dot_h) ** 2)


def ggx_lambda(cosine, alpha2):
    tan2 = np.maximum(1.0 / np.maximum(cosine * cosine, 1e-300) - 1.0, 0.0)
    return 0.5 * (np.sqrt(1.0 + alpha2 * tan2) - 1.0)


def ggx_times_cosine(n_dot_l, n_dot_v, n_dot_h, alpha2):
    """f_s * cos(theta_l) of the white GGX Glossy BSDF: D G2 / (4 cos(theta_v)), 0 below the horizon."""
    lit = (n_dot_l > 0.0) & (n_dot_v > 0.0) & (alpha2 > MIRROR_ALPHA2)
    g2 = 1.0 / (1.0 + ggx_lambda(n_dot_l, alpha2) + ggx_lambda(n_dot_v, alpha2))
    value = ggx_d(n_dot_h, alpha2) * g2 / (4.0 * np.maximum(n_dot_v, 1e-12))
    return np.where(lit, value, 0.0)


def lambert_times_cosine(n_dot_l):
    return np.maximum(n_dot_l, 0.0) / np.pi


# --- materials ---------------------------------------------------------------------------


@dataclass(frozen=True)
class Porous:
    """The porous BRDF (docs/model.md §2) with the weights of a light mode.

    ``light_mode`` EXACT evaluates the weights at every light direction (the ground truth);
    AMBIENT uses model.py's ambient weights; a 3-vector is a key sun's direction (towards
    it), whose weights every light then reuses, as the key-light material does.
    ``alpha=0`` is the base Diffuse + Glossy material.
    """

    kd: tuple = (0.8, 0.8, 0.8)
    ks: float = 0.1
    m: float = 0.4
    alpha: float = 0.2
    sp: float = 2.0
    light_mode: object = EXACT

    def weights(self, normal, n_dot_l, n_dot_v):
        """(k_d,poro (..., 3), k_s,poro (...)) for light at cosines ``n_dot_l`` (P, K)."""
        if isinstance(self.light_mode, str) and self.light_mode == AMBIENT:
            n_dot_l = None
        elif not isinstance(self.light_mode, str):
            key = np.asarray(self.light_mode, dtype=np.float64)
            n_dot_l = np.broadcast_to((normal @ (key / np.linalg.norm(key)))[:, None], n_dot_l.shape)
        kd_poro, ks_poro = model.porous_coefficients(
            np.asarray(self.kd, dtype=np.float64), self.ks, self.m, self.alpha, self.sp, n_dot_l, n_dot_v[:, None]
        )
        shape = np.shape(n_dot_v[:, None] if n_dot_l is None else n_dot_l)
        return np.broadcast_to(kd_poro, (*shape, 3)), np.broadcast_to(ks_poro, shape)


def reflected(material, normal, directions, irradiance):
    """Radiance towards the viewer, (P, K, 3), from light arriving along unit ``directions``
    (P, K, 3) with irradiance ``irradiance`` (P, K) on a plane facing the light."""
    n_dot_l = np.einsum("pi,pki->pk", normal, directions)
    n_dot_v = normal @ VIEW
    half = directions + VIEW
    n_dot_h = np.einsum("pi,pki->pk", normal, half) / np.linalg.norm(half, axis=-1).clip(1e-12)
    kd_poro, ks_poro = material.weights(normal, n_dot_l, n_dot_v)
    diffuse = lambert_times_cosine(n_dot_l)
    glossy = ggx_times_cosine(n_dot_l, n_dot_v[:, None], n_dot_h, ggx_alpha2(material.m))
    return (kd_poro * diffuse[..., None] + (ks_poro * glossy)[..., None]) * irradiance[..., None]


# --- scenes ------------------------------------------------------------------------------


@dataclass
class Surface:
    """What each pixel of the camera sees: a point, its unit normal, and whether it is covered.

    ``faces`` are the planar parallelograms (origin, edge, edge) of the scene that can cast
    shadows on it; a convex scene has none.
    """

    position: np.ndarray
    normal: np.ndarray
    covered: np.ndarray
    faces: tuple = ()


def pixel_grid(size, scale=ORTHO_SCALE):
    """World x and y of each pixel centre, (size, size), row 0 at the top (largest y)."""
    coords = ((np.arange(size) + 0.5) / size - 0.5) * scale
    return np.meshgrid(coords, -coords)


def sphere(size, radius=1.0):
    """A sphere at the origin (studio.add_sphere)."""
    x, y = pixel_grid(size)
    z2 = radius * radius - x * x - y * y
    covered = z2 > 0.0
    position = np.stack([x, y, np.sqrt(np.maximum(z2, 0.0))], axis=-1)
    return Surface(position, position / radius, covered)


def plane(size, half=1.0):
    """A square facing +Z at the origin (studio.add_plane with size 2 * half)."""
    x, y = pixel_grid(size)
    position = np.stack([x, y, np.zeros_like(x)], axis=-1)
    normal = np.broadcast_to(VIEW, position.shape).copy()
    return Surface(position, normal, (np.abs(x) < half) & (np.abs(y) < half))


def v_groove_faces(slope_degrees=45.0, half=1.0):
    """The two faces of a V-groove along Y, its bottom on the Y axis, rising at ``slope_degrees``."""
    rise = half * np.tan(np.radians(slope_degrees))
    left = (np.array([-half, -half, rise]), np.array([half, 0.0, -rise]), np.array([0.0, 2 * half, 0.0]))
    right = (np.array([0.0, -half, 0.0]), np.array([half, 0.0, rise]), np.array([0.0, 2 * half, 0.0]))
    return left, right


def v_groove(size, slope_degrees=45.0, half=1.0):
    """A V-groove (benchmarks' add_v_groove): the two faces shadow each other."""
    x, y = pixel_grid(size)
    slope = np.tan(np.radians(slope_degrees))
    position = np.stack([x, y, slope * np.abs(x)], axis=-1)
    normal = np.stack([-np.sign(x) * slope, np.zeros_like(x), np.ones_like(x)], axis=-1)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    covered = (np.abs(x) < half) & (np.abs(y) < half) & (x != 0.0)
    return Surface(position, normal, covered, v_groove_faces(slope_degrees, half))


def unoccluded(faces, points, directions, distance=np.inf):
    """(P, K) True where the ray from ``points`` (P, 3) along ``directions`` (P, K, 3) reaches
    ``distance`` without crossing a face."""
    free = np.ones(directions.shape[:2], dtype=bool)
    for origin, edge_u, edge_v in faces:
        face_normal = np.cross(edge_u, edge_v)
        facing = directions @ face_normal
        t = ((origin - points) @ face_normal)[:, None] / np.where(facing == 0.0, np.nan, facing)
        hit = points[:, None, :] + t[..., None] * directions - origin
        u = _coordinate(hit, edge_u, edge_v)
        v = _coordinate(hit, edge_v, edge_u)
        with np.errstate(invalid="ignore"):
            free &= ~((t > 1e-9) & (t < distance) & (u >= 0) & (u <= 1) & (v >= 0) & (v <= 1))
    return free


def _coordinate(offset, edge, other):
    """The coefficient of ``edge`` in ``offset`` = a edge + b other (both edges in the face)."""
    normal = np.cross(edge, other)
    dual = np.cross(other, normal) / (normal @ normal)
    return offset @ dual


# --- lights ------------------------------------------------------------------------------


@dataclass(frozen=True)
class Sun:
    """A sun of zero angle (studio.add_sun); ``towards`` points at it."""

    towards: tuple = (0.0, 0.0, 1.0)
    strength: float = 3.0

    def incident(self, points):
        direction = np.asarray(self.towards, dtype=np.float64)
        direction = np.broadcast_to(direction / np.linalg.norm(direction), (len(points), 1, 3))
        return direction, np.full((len(points), 1), self.strength), np.inf


@dataclass(frozen=True)
class PointLight:
    """A point light of zero radius (probes.add_point_light)."""

    location: tuple = (0.0, 0.0, 3.0)
    power: float = 1000.0

    def incident(self, points):
        offset = (np.asarray(self.location) - points)[:, None, :]
        distance = np.linalg.norm(offset, axis=-1)
        return offset / distance[..., None], self.power / (4.0 * np.pi * distance**2), distance


@dataclass(frozen=True)
class AreaLight:
    """A square area light facing down -Z (probes.add_point_light(kind="AREA"), unrotated),
    integrated by the midpoint rule on ``resolution``^2 patches (error O(resolution^-2))."""

    location: tuple = (0.0, 0.0, 3.0)
    size: float = 1.0
    power: float = 1000.0
    resolution: int = 48

    def incident(self, points):
        n = self.resolution
        offsets = ((np.arange(n) + 0.5) / n - 0.5) * self.size
        u, v = np.meshgrid(offsets, offsets)
        patches = np.asarray(self.location) + np.stack([u.ravel(), v.ravel(), np.zeros(n * n)], axis=-1)
        offset = patches[None, :, :] - points[:, None, :]
        distance = np.linalg.norm(offset, axis=-1)
        direction = offset / distance[..., None]
        radiance = self.power / (np.pi * self.size**2)
        cos_light = np.maximum(direction[..., 2], 0.0)  # the light faces -Z: lit below it
        return direction, radiance * cos_light * (self.size / n) ** 2 / distance**2, distance


@dataclass(frozen=True)
class Sky:
    """A world of radiance L(direction): UNIFORM (L = strength everywhere) or OVERCAST
    (the CIE overcast sky, L = strength (1 + 2 cos(zenith)) / 3 above the horizon, a black
    ground below)."""

    kind: str = "UNIFORM"
    strength: float = 1.0

    def radiance(self, directions):
        if self.kind == "UNIFORM":
            return np.full(directions.shape[:-1], self.strength)
        z = directions[..., 2]
        return np.where(z >= 0.0, self.strength * (1.0 + 2.0 * z) / 3.0, 0.0)


# --- the renderer ------------------------------------------------------------------------


@dataclass
class Image:
    """Linear RGB radiance (H, W, 3), the covered mask, and a per-pixel bound on the error of
    the Monte Carlo part (3 standard errors: exceeded with probability ~0.3% per pixel)."""

    rgb: np.ndarray
    covered: np.ndarray
    bound: np.ndarray


def render(surface, material, lights=(), sky=None, samples=4096, seed=0, batch=256):
    """Direct lighting of ``surface`` in ``material`` by ``lights`` and an optional ``sky``."""
    points = surface.position[surface.covered]
    normal = surface.normal[surface.covered]
    total = np.zeros((len(points), 3))
    for light in lights:
        directions, irradiance, distance = light.incident(points)
        visible = unoccluded(surface.faces, points, directions, distance)
        total += reflected(material, normal, directions, irradiance * visible).sum(axis=1)
    error = np.zeros(len(points))
    if sky is not None:
        mean, error = sky_radiance(surface, material, sky, points, normal, samples, seed, batch)
        total += mean
    shape = surface.covered.shape
    rgb, bound = np.zeros((*shape, 3)), np.zeros(shape)
    rgb[surface.covered], bound[surface.covered] = total, error
    return Image(rgb, surface.covered, bound)


def sky_radiance(surface, material, sky, points, normal, samples, seed, batch):
    """Monte Carlo estimate of the sky's reflected radiance, (P, 3), and its 3-sigma bound (P,).

    Directions are drawn from the cosine lobe or from GGX's distribution of visible normals,
    in proportion k_d : k_s (one-sample MIS with the mixture pdf); a mirror-sharp GGX lobe
    is added exactly along the reflected view direction instead.
    """
    rng = np.random.default_rng(seed)
    alpha2 = float(ggx_alpha2(material.m))
    mirror = alpha2 <= MIRROR_ALPHA2
    glossy_share = 0.0 if mirror else material.ks / max(material.ks + float(np.mean(material.kd)), 1e-12)
    tangent, bitangent = orthonormal_basis(normal)
    to_local = np.stack([tangent, bitangent, normal], axis=1)  # rows: the local axes
    view_local = to_local @ VIEW
    total, total_sq = np.zeros((len(points), 3)), np.zeros((len(points), 3))
    for start in range(0, samples, batch):
        k = min(batch, samples - start)
        u = rng.random((3, len(points), k))
        local = np.where(
            (u[2] < glossy_share)[..., None],
            sample_vndf(view_local, np.sqrt(alpha2), u[0], u[1]),
            sample_cosine(u[0], u[1]),
        )
        directions = np.einsum("pji,pkj->pki", to_local, local)
        pdf = mixture_pdf(local, view_local, alpha2, glossy_share)
        weight = np.where(pdf > 0.0, sky.radiance(directions) / np.maximum(pdf, 1e-300), 0.0)
        weight = weight * unoccluded(surface.faces, points, directions)
        value = reflected(material, normal, directions, weight)
        total += value.sum(axis=1)
        total_sq += (value**2).sum(axis=1)
    mean = total / samples
    variance = np.maximum(total_sq / samples - mean**2, 0.0) / samples
    bound = 3.0 * np.sqrt(variance.max(axis=-1))
    if mirror and material.ks > 0.0:
        mean += mirror_reflection(surface, material, sky, points, normal)
    return mean, bound


def mirror_reflection(surface, material, sky, points, normal):
    reflection = (2.0 * (normal @ VIEW)[:, None] * normal - VIEW)[:, None, :]
    radiance = sky.radiance(reflection) * unoccluded(surface.faces, points, reflection)
    kd_poro, ks_poro = material.weights(normal, np.einsum("pi,pki->pk", normal, reflection), normal @ VIEW)
    return (ks_poro * radiance)[:, 0, None] * np.ones(3)


def orthonormal_basis(normal):
    """Two unit tangents completing each unit normal (P, 3) to a right-handed frame."""
    sign = np.where(normal[:, 2] >= 0.0, 1.0, -1.0)
    a = -1.0 / (sign + normal[:, 2])
    b = normal[:, 0] * normal[:, 1] * a
    tangent = np.stack([1.0 + sign * normal[:, 0] ** 2 * a, sign * b, -sign * normal[:, 0]], axis=-1)
    bitangent = np.stack([b, sign + normal[:, 1] ** 2 * a, -normal[:, 1]], axis=-1)
    return tangent, bitangent


def sample_cosine(u1, u2):
    radius, phi = np.sqrt(u1), 2.0 * np.pi * u2
    return np.stack([radius * np.cos(phi), radius * np.sin(phi), np.sqrt(np.maximum(1.0 - u1, 0.0))], axis=-1)


def sample_vndf(view, alpha, u1, u2):
    """Light directions (P, K, 3, local) reflected about GGX visible normals (Heitz 2018)."""
    v = view[:, None, :]
    vh = np.concatenate([alpha * v[..., :2], v[..., 2:]], axis=-1)
    vh = vh / np.linalg.norm(vh, axis=-1, keepdims=True)
    length2 = vh[..., 0] ** 2 + vh[..., 1] ** 2
    safe = np.sqrt(np.maximum(length2, 1e-300))
    t1 = np.where(
        (length2 > 0)[..., None],
        np.stack([-vh[..., 1], vh[..., 0], 0 * safe], -1) / safe[..., None],
        np.array([1.0, 0.0, 0.0]),
    )
    t2 = np.cross(vh, t1)
    radius, phi = np.sqrt(u1), 2.0 * np.pi * u2
    p1, p2 = radius * np.cos(phi), radius * np.sin(phi)
    s = 0.5 * (1.0 + vh[..., 2])
    p2 = (1.0 - s) * np.sqrt(np.maximum(1.0 - p1 * p1, 0.0)) + s * p2
    nh = p1[..., None] * t1 + p2[..., None] * t2 + np.sqrt(np.maximum(1.0 - p1 * p1 - p2 * p2, 0.0))[..., None] * vh
    h = np.stack([alpha * nh[..., 0], alpha * nh[..., 1], np.maximum(nh[..., 2], 0.0)], axis=-1)
    h = h / np.linalg.norm(h, axis=-1, keepdims=True).clip(1e-300)
    v_dot_h = np.einsum("pki,pki->pk", np.broadcast_to(v, h.shape), h)
    return 2.0 * v_dot_h[..., None] * h - v


def mixture_pdf(local, view, alpha2, glossy_share):
    """The pdf of ``local`` directions under the cosine/VNDF mixture (solid angle)."""
    cosine = np.maximum(local[..., 2], 0.0) / np.pi
    if glossy_share == 0.0:
        return cosine * (local[..., 2] > 0)
    v = view[:, None, :]
    half = local + v
    half = half / np.linalg.norm(half, axis=-1, keepdims=True).clip(1e-300)
    n_dot_v = v[..., 2]
    g1 = 1.0 / (1.0 + ggx_lambda(n_dot_v, alpha2))
    vndf = g1 * ggx_d(half[..., 2], alpha2) / (4.0 * n_dot_v)
    pdf = (1.0 - glossy_share) * cosine + glossy_share * vndf
    return np.where(local[..., 2] > 0.0, pdf, 0.0)


# --- comparing images --------------------------------------------------------------------


def errors(image, reference, mask):
    """(relative RMSE, relative max error) of ``image`` against ``reference`` over ``mask``,
    both relative to the reference's RMS value there (so 0.01 is '1% RMSE')."""
    difference = (np.asarray(image)[..., :3] - reference)[mask]
    scale = np.sqrt(np.mean(reference[mask] ** 2))
    return float(np.sqrt(np.mean(difference**2)) / scale), float(np.abs(difference).max() / scale)
