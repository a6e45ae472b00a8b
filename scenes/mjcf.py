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
    """Format numbers as an MJCF attribute: space-separated, 6 significant digits.

    Parameters
    ----------
    values : float or array_like
        The numbers (flattened).

    Returns
    -------
    str
        The attribute's text.
    """
    return " ".join(f"{float(v):.6g}" for v in np.ravel(values))


class SceneBuilder:
    """Collects assets and world geometry; ``to_xml()`` gives the model, ``assets`` its files.

    Parameters
    ----------
    model_name : str
        The ``<mujoco model=...>`` name.
    """

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
        """Add a 2-D texture from an RGB image, stored as a PNG asset.

        Parameters
        ----------
        name : str
            The texture's name (its file is ``<name>.png``).
        image : ndarray of shape (H, W, 3), uint8
            The image.

        Returns
        -------
        str
            ``name``.
        """
        file = f"{self._claim(name)}.png"
        self.assets[file] = encode_png(image)
        ET.SubElement(self.asset, "texture", name=name, type="2d", file=file)
        return name

    def builtin_texture(self, name: str, **attrs) -> str:
        """Add one of MuJoCo's built-in textures (``builtin="gradient"`` and so on).

        Parameters
        ----------
        name : str
            The texture's name.
        **attrs
            The ``<texture>`` element's other attributes, as strings.

        Returns
        -------
        str
            ``name``.
        """
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
        """Add a material, textured or plain.

        Parameters
        ----------
        name : str
            The material's name.
        texture : str or None, default None
            The texture's name; None: plain colour.
        rgba : sequence of float, default (1, 1, 1, 1)
            Colour (and opacity), 0..1.
        texrepeat : sequence of float, default (1, 1)
            Texture repeats (per metre with ``texuniform``).
        texuniform : bool, default True
            Whether the texture repeats per metre rather than per face.
        specular, shininess, reflectance : float
            MuJoCo's material settings (defaults 0.1, 0.1, 0.0).

        Returns
        -------
        str
            ``name``.
        """
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
        """Add a mesh asset, embedded inline.

        Parameters
        ----------
        name : str
            The mesh's name.
        mesh : Mesh
            Its vertices, faces and optional texture coordinates.

        Returns
        -------
        str
            ``name``.
        """
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
        """Add a box geom; a colliding one leaves a `Footprint`.

        Parameters
        ----------
        name : str
            The geom's name.
        center : sequence of float
            (x, y, z) of its centre, m.
        half_size : sequence of float
            (hx, hy, hz), m.
        material : str or None, default None
            Its material.
        yaw : float, default 0.0
            Rotation about z, rad.
        collide : bool, default True
            Whether it collides (else visual only).
        group : int, default names.GROUP_SOLID
            Its geom group.
        rgba : sequence of float or None, default None
            Its colour, instead of the material's.

        Returns
        -------
        xml.etree.ElementTree.Element
            The ``<geom>`` element.
        """
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
        """Add an upright cylinder geom; a colliding one leaves a disc `Footprint`.

        Parameters
        ----------
        name : str
            The geom's name.
        center : sequence of float
            (x, y, z) of its centre, m.
        radius : float
            Its radius, m.
        half_height : float
            Half its height, m.
        material : str or None, default None
            Its material.
        collide : bool, default True
            Whether it collides (else visual only).
        group : int, default names.GROUP_SOLID
            Its geom group.
        rgba : sequence of float or None, default None
            Its colour, instead of the material's.

        Returns
        -------
        xml.etree.ElementTree.Element
            The ``<geom>`` element.
        """
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
        """Add a visual-only mesh geom (collision comes from primitive proxies placed beside it).

        Parameters
        ----------
        name : str
            The geom's name.
        mesh : str
            The mesh asset's name.
        pos : sequence of float
            (x, y, z) of the mesh's origin, m.
        material : str or None, default None
            Its material.
        group : int, default names.GROUP_DECOR
            Its geom group.
        rgba : sequence of float or None, default None
            Its colour, instead of the material's.

        Returns
        -------
        xml.etree.ElementTree.Element
            The ``<geom>`` element.
        """
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
        """Add a spot or directional light.

        Parameters
        ----------
        name : str
            The light's name.
        pos : sequence of float
            (x, y, z), m.
        direction : sequence of float, default (0, 0, -1)
            The direction it shines in.
        diffuse, ambient, specular : sequence of float
            Its colours, 0..1 per channel.
        directional : bool, default False
            Directional (else a spot light).
        attenuation : sequence of float, default (1.0, 0.0, 0.0)
            Constant, linear and quadratic attenuation.
        cutoff : float, default 90.0
            The spot's cutoff angle, degrees.
        castshadow : bool, default False
            Whether it casts shadows.

        Returns
        -------
        xml.etree.ElementTree.Element
            The ``<light>`` element.
        """
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
        """Add a fixed camera.

        Parameters
        ----------
        name : str
            The camera's name.
        pos : sequence of float
            (x, y, z), m.
        xyaxes : sequence of float
            The camera frame's x and y axes (6 numbers).

        Returns
        -------
        xml.etree.ElementTree.Element
            The ``<camera>`` element.
        """
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
        """Set the off-screen buffer, clipping planes and headlight.

        ``znear``/``zfar`` are multiples of the model extent, so a 40 m world needs a tiny znear
        or the camera clips everything within half a metre.

        Parameters
        ----------
        extent : float
            The model's extent, m.
        center : sequence of float
            The model's centre (x, y, z), m.
        headlight_ambient, headlight_diffuse : float, default 0.3
            The headlight's grey levels.
        width, height : int, default 320, 240
            The off-screen buffer's size, pixels.
        fog : tuple of float or None, default None
            MuJoCo's ``fogstart`` and ``fogend``; None: MuJoCo's defaults.
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
        """Return the model as an indented MJCF string.

        Returns
        -------
        str
            The XML.
        """
        ET.indent(self.root)
        return ET.tostring(self.root, encoding="unicode")
