"""A small MJCF builder: named textures, materials, meshes, geoms and lights -> XML string.

Worlds are described by compact layouts (``scenes/hallway.py``, ``scenes/lawn.py``) and turned
into MJCF here. Every element gets a name; colliding geoms also leave a floor
`Footprint` behind for the free-space ground truth.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np

from scenes import names
from scenes.meshes import Mesh
from scenes.regions import Footprint
from scenes.textures import encode_png


def fmt(values) -> str:
    """Numbers as an MJCF attribute: space-separated, 6 significant digits."""
    return " ".join(f"{float(v):.6g}" for v in np.ravel(values))


class SceneBuilder:
    """Collects assets and world geometry; ``to_xml()`` gives the model, ``assets`` its files."""

    def __init__(self, model_name: str):
        self.root = ET.Element("mujoco", model=model_name)
        ET.SubElement(self.root, "compiler", angle="radian", autolimits="true")
        self.option = ET.SubElement(
            self.root, "option", timestep="0.01", integrator="implicitfast", gravity="0 0 -9.81"
        )
        self.visual = ET.SubElement(self.root, "visual")
        self.asset = ET.SubElement(self.root, "asset")
        self.worldbody = ET.SubElement(self.root, "worldbody")
        self.actuator = ET.SubElement(self.root, "actuator")
        self.assets: dict[str, bytes] = {}
        self.footprints: list[Footprint] = []
        self._names: set[str] = set()

    def _claim(self, name: str) -> str:
        if name in self._names:
            raise ValueError(f"duplicate element name {name!r}")
        self._names.add(name)
        return name

    # -- assets -----------------------------------------------------------------------------
    def texture(self, name: str, image: np.ndarray) -> str:
        """A 2-D texture from an RGB image, stored as a PNG asset."""
        file = f"{self._claim(name)}.png"
        self.assets[file] = encode_png(image)
        ET.SubElement(self.asset, "texture", name=name, type="2d", file=file)
        return name

    def builtin_texture(self, name: str, **attrs) -> str:
        ET.SubElement(self.asset, "texture", name=self._claim(name), **attrs)
        return name

    def material(
        self,
        name: str,
        texture: str | None = None,
        rgba=(1, 1, 1, 1),
        texrepeat=(1, 1),
        texuniform: bool = True,
        specular: float = 0.1,
        shininess: float = 0.1,
        reflectance: float = 0.0,
    ) -> str:
        attrs = {
            "name": self._claim(name),
            "rgba": fmt(rgba),
            "specular": fmt(specular),
            "shininess": fmt(shininess),
            "reflectance": fmt(reflectance),
        }
        if texture is not None:
            attrs.update(
                texture=texture, texrepeat=fmt(texrepeat), texuniform=str(texuniform).lower()
            )
        ET.SubElement(self.asset, "material", **attrs)
        return name

    def mesh(self, name: str, mesh: Mesh) -> str:
        attrs = {"texcoord": mesh.texcoord_attr()} if mesh.texcoords is not None else {}
        ET.SubElement(
            self.asset,
            "mesh",
            name=self._claim(name),
            vertex=mesh.vertex_attr(),
            face=mesh.face_attr(),
            **attrs,
        )
        return name

    # -- geometry ---------------------------------------------------------------------------
    def _geom(self, parent, name, collide, group, **attrs) -> ET.Element:
        attrs = {k: v for k, v in attrs.items() if v is not None}
        if not collide:
            attrs.update(contype="0", conaffinity="0")
        return ET.SubElement(
            parent if parent is not None else self.worldbody,
            "geom",
            name=self._claim(name),
            group=str(group),
            **attrs,
        )

    def box(
        self,
        name: str,
        center,
        half_size,
        material: str | None = None,
        yaw: float = 0.0,
        collide: bool = True,
        group: int = names.GROUP_SOLID,
        rgba=None,
    ) -> ET.Element:
        """A box; ``center`` (x, y, z) and ``half_size`` (hx, hy, hz) in metres."""
        if collide:
            self.footprints.append(
                Footprint(
                    name, (float(center[0]), float(center[1])), (half_size[0], half_size[1]), yaw
                )
            )
        return self._geom(
            None,
            name,
            collide,
            group,
            type="box",
            pos=fmt(center),
            size=fmt(half_size),
            euler=fmt((0, 0, yaw)) if yaw else None,
            material=material,
            rgba=fmt(rgba) if rgba is not None else None,
        )

    def cylinder(
        self,
        name: str,
        center,
        radius: float,
        half_height: float,
        material: str | None = None,
        collide: bool = True,
        group: int = names.GROUP_SOLID,
        rgba=None,
    ) -> ET.Element:
        if collide:
            self.footprints.append(
                Footprint(name, (float(center[0]), float(center[1])), radius=float(radius))
            )
        return self._geom(
            None,
            name,
            collide,
            group,
            type="cylinder",
            pos=fmt(center),
            size=fmt((radius, half_height)),
            material=material,
            rgba=fmt(rgba) if rgba is not None else None,
        )

    def mesh_geom(
        self,
        name: str,
        mesh: str,
        pos,
        material: str | None = None,
        group: int = names.GROUP_DECOR,
        rgba=None,
    ) -> ET.Element:
        """A visual-only mesh (collision comes from primitive proxies placed beside it)."""
        return self._geom(
            None,
            name,
            False,
            group,
            type="mesh",
            mesh=mesh,
            pos=fmt(pos),
            material=material,
            rgba=fmt(rgba) if rgba is not None else None,
        )

    def light(
        self,
        name: str,
        pos,
        direction=(0, 0, -1),
        diffuse=(0.7, 0.7, 0.7),
        ambient=(0.0, 0.0, 0.0),
        specular=(0.2, 0.2, 0.2),
        directional: bool = False,
        attenuation=(1.0, 0.0, 0.0),
        cutoff: float = 90.0,
        castshadow: bool = False,
    ) -> ET.Element:
        return ET.SubElement(
            self.worldbody,
            "light",
            name=self._claim(name),
            pos=fmt(pos),
            dir=fmt(direction),
            diffuse=fmt(diffuse),
            ambient=fmt(ambient),
            specular=fmt(specular),
            type="directional" if directional else "spot",
            attenuation=fmt(attenuation),
            cutoff=fmt(cutoff),
            castshadow=str(castshadow).lower(),
        )

    def camera(self, name: str, pos, xyaxes) -> ET.Element:
        return ET.SubElement(
            self.worldbody, "camera", name=self._claim(name), pos=fmt(pos), xyaxes=fmt(xyaxes)
        )

    def set_visual(
        self,
        extent: float,
        center,
        headlight_ambient=0.3,
        headlight_diffuse=0.3,
        width: int = 320,
        height: int = 240,
        fog: tuple | None = None,
    ) -> None:
        """Off-screen buffer, clipping planes and headlight.

        ``znear``/``zfar`` are multiples of the model extent, so a 40 m world needs a tiny znear
        or the camera clips everything within half a metre.
        """
        ET.SubElement(self.root, "statistic", extent=fmt(extent), center=fmt(center))
        ET.SubElement(self.visual, "global", offwidth=str(width), offheight=str(height), fovy="45")
        # offsamples=0: multisampling is what costs most on a software rasteriser.
        ET.SubElement(self.visual, "quality", offsamples="0", shadowsize="2048")
        map_attrs = {"znear": fmt(0.02 / extent), "zfar": fmt(3.0)}
        if fog is not None:
            map_attrs.update(fogstart=fmt(fog[0]), fogend=fmt(fog[1]))
        ET.SubElement(self.visual, "map", **map_attrs)
        ET.SubElement(
            self.visual,
            "headlight",
            ambient=fmt([headlight_ambient] * 3),
            diffuse=fmt([headlight_diffuse] * 3),
            specular="0 0 0",
        )

    def to_xml(self) -> str:
        ET.indent(self.root)
        return ET.tostring(self.root, encoding="unicode")
