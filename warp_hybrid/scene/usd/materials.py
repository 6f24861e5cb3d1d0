"""UsdShade materials -> ``Material`` entries of the scene's material table.

Binding: ``UsdShade.MaterialBindingAPI.ComputeBoundMaterial`` (purpose ``full``,
falling back to all-purpose), so bindings inherited from ancestors, collection
bindings and instance-root bindings resolve the way pxr defines them; per-face
``GeomSubset`` bindings (family ``materialBind``) are honoured by the mesh reader.

Surface: the universal-render-context surface output must lead to a
``UsdPreviewSurface``; other render contexts' outputs are other renderers' (a material
that also carries ``outputs:mtlx:surface`` is drawn with its UsdPreviewSurface, without
a warning).  MaterialX cannot be read (usd-core ships no MaterialX plugin): a material
whose only surface is a MaterialX network (``outputs:mtlx:surface``, or a universal
surface shader with an ``ND_*`` id) is drawn default grey with one warning naming it,
as is any other material without a UsdPreviewSurface.  Inputs diffuseColor, emissiveColor, specularColor,
useSpecularWorkflow, metallic, roughness, opacity, opacityThreshold and ior are read as
constants or, for diffuse/emissive/roughness/metallic/opacity/normal, from a ``UsdUVTexture``
(file resolved by pxr relative to the layer that authored it; sourceColorSpace;
wrapS/wrapT; scale/bias; the connected output picks the channel) whose ``st`` comes
from a ``UsdPrimvarReader_float2``, through any ``UsdTransform2d`` nodes (their
composed affine map goes to the binding, ``texture_transform``).  A UsdUVTexture
with no file gives its ``fallback`` (times scale, plus bias) as a constant.
``diffuseColor`` fed by a ``UsdPrimvarReader_float3``/``_float`` follows that primvar
per corner (``Material.diffuse_primvar``); other inputs fed by a primvar reader take
the reader's fallback (warned).  A textured slot's constant keeps the input's
schema default: the texture replaces it.  ``wrap = useMetadata`` means repeat
(OpenCV exposes no wrap metadata).  ``normal`` is a tangent-space normal map
(``Material.normal_texture``): its rgb times scale plus bias is the normal, used as
authored (the usual 8-bit encoding authors scale (2, 2, 2, 1) and bias (-1, -1, -1,
0); scale 1, bias 0 reads the texels as they are); ``sourceColorSpace = auto`` reads
it raw (a normal map holds data, not colour); a missing file gives a flat normal map,
not the checker.  A constant ``normal`` other than (0, 0, 1) is ignored (warned).
Material ``customData`` ``sa:thinWalled``, ``sa:attenuationColor`` and
``sa:attenuationDistance`` fill the volume fields.  ``doubleSided`` comes from the
mesh, so one USD material can give two entries.

Opacity below 1 with ``opacityThreshold`` 0 is one of two things.  Glass (tinted
transmission with Fresnel; refraction unless thin-walled) where the material authors
glass optics: an ``ior`` input, or ``sa:thinWalled`` / ``sa:attenuation*``.  Otherwise,
and always under ``opacityMode = "presence"``, it is coverage: alpha blending
(``Material.alpha_blended``), as Storm draws it.

Parameters are read once per source (at the first time code evaluated).  Anything
else (other shader types, displacement, clearcoat, occlusion, constant normals,
textures on unsupported inputs) is reported once per material.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from pxr import Sdf, Usd, UsdShade

from ..model import Material, Wrap
from .primvars import PRIMVAR_READERS, PrimvarInput, primvar_input
from .texture_transform import UV_TRANSFORM_ID, as_rows, transform2d_matrix
from .textures import CHECKER_NAME, FLAT_NORMAL_NAME, ImageLibrary
from .validate import Diagnostics

_WRAPS = {
    "repeat": Wrap.REPEAT,
    "clamp": Wrap.CLAMP,
    "mirror": Wrap.MIRROR,
    "black": Wrap.BLACK,
    "useMetadata": Wrap.REPEAT,
}
_CHANNELS = {"rgb": -1, "rgba": -1, "r": 0, "g": 1, "b": 2, "a": 3}
NORMAL_INPUT = "normal"
_FLAT_NORMAL = (0.0, 0.0, 1.0)
# Inputs the renderer ignores, with their neutral values: warn when set otherwise.
_UNSUPPORTED_INPUTS = {
    "displacement": 0.0,
    "occlusion": 1.0,
    "clearcoat": 0.0,
    "clearcoatRoughness": 0.01,
}
DEFAULT_UV_SET = "st"
# MaterialX: usd-core ships no MaterialX plugin, so such networks cannot be read.
MATERIALX_CONTEXT = "mtlx"
MATERIALX_NODE_PREFIX = "ND_"


@dataclass
class _TextureRef:
    """A texture binding feeding a slot, the channel it reads, its uv primvar."""

    binding: int
    channel: int
    varname: str


def bound_material(prim: Usd.Prim) -> UsdShade.Material | None:
    """The material bound to ``prim`` for full rendering (inherited bindings included)."""
    mat, _rel = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial(UsdShade.Tokens.full)
    return mat if mat and mat.GetPrim().IsValid() else None


def _is_output(attr: Usd.Attribute) -> bool:
    return UsdShade.Utils.GetType(attr.GetName()) == UsdShade.AttributeType.Output


def _shader_text(shader: UsdShade.Shader) -> str:
    return f"{shader.GetPath()}, id {shader.GetShaderId()!r}"


def _materialx_surface(material: UsdShade.Material, universal: UsdShade.Shader | None) -> str | None:
    """How ``material``'s surface is a MaterialX network (its ``outputs:mtlx:surface``, or
    a universal surface shader whose id is a MaterialX node definition ``ND_*``), or None."""
    if universal is not None and str(universal.GetShaderId() or "").startswith(MATERIALX_NODE_PREFIX):
        return f"outputs:surface -> {_shader_text(universal)}"
    if not material.GetSurfaceOutput(MATERIALX_CONTEXT):
        return None
    shader, _name, _type = material.ComputeSurfaceSource(MATERIALX_CONTEXT)  # falls back to the universal one
    if shader and shader.GetPrim().IsValid() and (universal is None or shader.GetPrim() != universal.GetPrim()):
        return f"outputs:{MATERIALX_CONTEXT}:surface -> {_shader_text(shader)}"
    return f"outputs:{MATERIALX_CONTEXT}:surface"


def _no_preview_surface(material: UsdShade.Material, universal: UsdShade.Shader | None) -> str:
    """The warning for a material whose universal surface is not a UsdPreviewSurface
    (``universal``: the shader it leads to, None when it leads nowhere); it is drawn grey."""
    materialx = _materialx_surface(material, universal)
    if materialx is not None:
        return (
            f"material is a MaterialX network ({materialx}); MaterialX is not supported (usd-core has no "
            "MaterialX plugin) and the material has no UsdPreviewSurface on outputs:surface; using default grey"
        )
    if universal is None:
        contexts = [o.GetBaseName() for o in material.GetSurfaceOutputs()]
        return f"material has no universal UsdPreviewSurface surface (surface outputs: {contexts}); using default grey"
    shader_id = universal.GetShaderId()
    return f"surface shader {universal.GetPath()} is {shader_id!r}, not UsdPreviewSurface; using default grey"


class MaterialLibrary:
    """The material table of one scene source, grown as meshes ask for materials.

    Entries are keyed by (material prim path, doubleSided); ``uv_primvar[i]`` is the
    primvar the textures of material ``i`` read (``st`` when it has none).
    """

    def __init__(self, images: ImageLibrary, diag: Diagnostics, time: float) -> None:
        """Textures go to ``images``, warnings to ``diag``; inputs are read at ``time``."""
        self.images = images
        self.diag = diag
        self.time = Usd.TimeCode(time)
        self.materials: list[Material] = []
        self.uv_primvar: list[str] = []
        self._index: dict[tuple[str, bool], int] = {}
        self._parsed: dict[str, tuple[Material, str]] = {}

    def _add(self, key: tuple[str, bool], material: Material, uv: str) -> int:
        self.materials.append(material)
        self.uv_primvar.append(uv)
        self._index[key] = len(self.materials) - 1
        return self._index[key]

    def default(self, double_sided: bool) -> int:
        """The grey UsdPreviewSurface default for meshes with no material or colour."""
        key = ("<default>", double_sided)
        if key in self._index:
            return self._index[key]
        return self._add(key, Material("<default>", double_sided=double_sided), DEFAULT_UV_SET)

    def vertex_colored(self, primvar: str, double_sided: bool) -> int:
        """The default material with its diffuse colour from the colour ``primvar`` per
        corner (an unbound mesh whose displayColor varies over it)."""
        key = (f"<{primvar} per corner>", double_sided)
        if key in self._index:
            return self._index[key]
        return self._add(key, Material(key[0], diffuse_primvar=primvar, double_sided=double_sided), DEFAULT_UV_SET)

    def display_color(self, mesh_path: str, color: tuple[float, float, float], double_sided: bool) -> int:
        """A material for an unbound mesh whose albedo is its displayColor."""
        key = (f"{mesh_path}:displayColor", double_sided)
        if key in self._index:
            return self._index[key]
        return self._add(key, Material(key[0], diffuse=color, double_sided=double_sided), DEFAULT_UV_SET)

    def index(self, material: UsdShade.Material, double_sided: bool) -> int:
        """Table index for ``material`` on a mesh with this ``doubleSided`` value."""
        path = str(material.GetPath())
        key = (path, double_sided)
        if key in self._index:
            return self._index[key]
        if path not in self._parsed:
            self._parsed[path] = self._parse(material)
        parsed, uv = self._parsed[path]
        return self._add(key, replace(parsed, double_sided=double_sided), uv)

    # -- parsing -------------------------------------------------------------------

    def _parse(self, material: UsdShade.Material) -> tuple[Material, str]:
        path = str(material.GetPath())
        shader, _name, _type = material.ComputeSurfaceSource("")
        if not shader or not shader.GetPrim().IsValid():
            shader = None
        if shader is None or shader.GetShaderId() != "UsdPreviewSurface":
            self.diag.warn(_no_preview_surface(material, shader), path)
            return Material(path), DEFAULT_UV_SET
        prim = material.GetPrim()
        m = Material(path)
        refs: list[_TextureRef] = []

        def colour(name: str, default: tuple[float, float, float]) -> tuple[tuple[float, float, float], int]:
            value, tex = self._slot(shader, name, path, is_colour=True, texturable=True)
            if isinstance(value, PrimvarInput):  # only diffuseColor follows a primvar (see _primvar_slot)
                m.diffuse_primvar = value.varname
                return value.fallback, -1
            if tex is not None:
                refs.append(tex)
                return default, tex.binding
            return (tuple(float(c) for c in value) if value is not None else default), -1

        def scalar(name: str, default: float, texturable: bool) -> tuple[float, int, int]:
            value, tex = self._slot(shader, name, path, is_colour=False, texturable=texturable)
            if tex is not None:
                refs.append(tex)
                return default, tex.binding, tex.channel
            return (float(value) if value is not None else default), -1, 0

        m.diffuse, m.diffuse_texture = colour("diffuseColor", m.diffuse)
        m.emissive, m.emissive_texture = colour("emissiveColor", m.emissive)
        spec, _ = self._slot(shader, "specularColor", path, is_colour=True, texturable=False)
        if spec is not None:
            m.specular = tuple(float(c) for c in spec)
        workflow, _ = self._slot(shader, "useSpecularWorkflow", path, is_colour=False, texturable=False)
        m.use_specular_workflow = bool(workflow) if workflow is not None else False
        m.metallic, m.metallic_texture, m.metallic_channel = scalar("metallic", m.metallic, True)
        m.roughness, m.roughness_texture, m.roughness_channel = scalar("roughness", m.roughness, True)
        m.opacity, m.opacity_texture, opacity_channel = scalar("opacity", m.opacity, True)
        if m.opacity_texture >= 0:
            m.opacity_channel = opacity_channel
        m.opacity_threshold, _, _ = scalar("opacityThreshold", m.opacity_threshold, False)
        ior, _ = self._slot(shader, "ior", path, is_colour=False, texturable=False)
        if ior is not None:
            m.ior = float(ior)
        m.normal_texture = self._normal_map(shader, path, refs)
        self._warn_unsupported_inputs(shader, path)
        glass = self._read_custom_data(prim, m) or ior is not None
        mode, _ = self._slot(shader, "opacityMode", path, is_colour=False, texturable=False)
        m.alpha_blended = str(mode) == "presence" or not glass
        varnames = list(dict.fromkeys(r.varname for r in refs))
        if len(varnames) > 1:
            self.diag.warn(f"textures read several uv primvars {varnames}; only {varnames[0]!r} is used", path)
        return m, (varnames[0] if varnames else DEFAULT_UV_SET)

    def _read_custom_data(self, prim: Usd.Prim, m: Material) -> bool:
        """The glass optics under the shader prim's ``sa:`` custom data into ``m``;
        whether any is authored."""
        thin = prim.GetCustomDataByKey("sa:thinWalled")
        if thin is not None:
            m.thin_walled = bool(thin)
        att = prim.GetCustomDataByKey("sa:attenuationColor")
        if att is not None:
            m.attenuation_color = tuple(float(c) for c in att)[:3]
        dist = prim.GetCustomDataByKey("sa:attenuationDistance")
        if dist is not None:
            m.attenuation_distance = float(dist)
        return thin is not None or att is not None or dist is not None

    def _normal_map(self, shader: UsdShade.Shader, path: str, refs: list[_TextureRef]) -> int:
        """The texture binding of the ``normal`` input (appended to ``refs``), or -1;
        a constant other than the flat (0, 0, 1) is warned and ignored."""
        value, tex = self._slot(shader, NORMAL_INPUT, path, is_colour=True, texturable=True)
        if tex is not None:
            refs.append(tex)
            return tex.binding
        if value is not None and not np.allclose(np.asarray(value, dtype=np.float64), _FLAT_NORMAL, atol=1e-6):
            self.diag.warn(f"UsdPreviewSurface input {NORMAL_INPUT} = {value} is not supported, ignored", path)
        return -1

    def _warn_unsupported_inputs(self, shader: UsdShade.Shader, path: str) -> None:
        for name, neutral in _UNSUPPORTED_INPUTS.items():
            inp = shader.GetInput(name)
            if not inp:
                continue
            attrs = inp.GetValueProducingAttributes(False)
            if not attrs:
                continue
            if _is_output(attrs[0]):
                self.diag.warn(f"UsdPreviewSurface input {name} is connected to a node; not supported, ignored", path)
                continue
            value = attrs[0].Get(self.time)
            if value is not None and not np.allclose(np.asarray(value, dtype=np.float64), neutral, atol=1e-6):
                self.diag.warn(f"UsdPreviewSurface input {name} = {value} is not supported, ignored", path)

    def _slot(
        self, shader: UsdShade.Shader, name: str, path: str, is_colour: bool, texturable: bool
    ) -> tuple[object, _TextureRef | None]:
        """(constant value or None for the default, texture reference or None)."""
        inp = shader.GetInput(name)
        if not inp:
            return None, None
        attrs = inp.GetValueProducingAttributes(False)
        if not attrs:
            return None, None
        attr = attrs[0]
        if not _is_output(attr):
            return attr.Get(self.time), None
        node = UsdShade.Shader(attr.GetPrim())
        output = UsdShade.Utils.GetBaseNameAndType(attr.GetName())[0]
        node_id = node.GetShaderId() if node else None
        if node_id in PRIMVAR_READERS:
            return self._primvar_slot(node, name, path, is_colour), None
        if node_id == "UsdUVTexture" and not self._asset(node)[1]:
            return self._texture_fallback(node, str(output), is_colour), None
        if node_id != "UsdUVTexture":
            self.diag.warn(
                f"input {name} is fed by {attr.GetPath()} ({node_id!r}); only UsdUVTexture is supported, using the default",
                path,
            )
            return None, None
        if not texturable:
            self.diag.warn(
                f"input {name} is textured ({node.GetPath()}); textures on {name} are not supported, using the default",
                path,
            )
            return None, None
        return None, self._texture(node, str(output), path, name, is_colour)

    def _primvar_slot(self, node: UsdShade.Shader, name: str, path: str, is_colour: bool) -> object:
        """Input ``name`` fed by the primvar reader ``node``: a ``PrimvarInput`` for
        diffuseColor (per-corner colours), else the reader's fallback (warned)."""
        reader = primvar_input(node, self.time)
        if name == "diffuseColor" and reader.varname:
            return reader
        if reader.varname:
            self.diag.warn(
                f"input {name} reads primvar {reader.varname!r} ({node.GetPath()}); only diffuseColor follows "
                f"primvars, using the reader's fallback {reader.fallback if is_colour else reader.fallback[0]}",
                path,
            )
        return reader.fallback if is_colour else reader.fallback[0]

    def _texture_fallback(self, node: UsdShade.Shader, output: str, is_colour: bool) -> object:
        """A UsdUVTexture with no file: its ``fallback`` (default (0, 0, 0, 1)) times its
        scale plus its bias, the channel of ``output`` (rgb for a colour input)."""
        fallback = np.asarray(self._node_value(node, "fallback", (0.0, 0.0, 0.0, 1.0)), dtype=np.float64)
        scale = np.asarray(self._node_value(node, "scale", (1.0, 1.0, 1.0, 1.0)), dtype=np.float64)
        bias = np.asarray(self._node_value(node, "bias", (0.0, 0.0, 0.0, 0.0)), dtype=np.float64)
        value = fallback * scale + bias
        channel = _CHANNELS.get(output, -1)
        if channel >= 0:
            return (float(value[channel]),) * 3 if is_colour else float(value[channel])
        return tuple(float(v) for v in value[:3]) if is_colour else float(value[0])

    def _node_value(self, node: UsdShade.Shader, name: str, default: object) -> object:
        inp = node.GetInput(name)
        if not inp:
            return default
        attrs = inp.GetValueProducingAttributes(False)
        if not attrs or _is_output(attrs[0]):
            return default
        value = attrs[0].Get(self.time)
        return default if value is None else value

    def _asset(self, node: UsdShade.Shader) -> tuple[str, str]:
        """(resolved path, authored path) of a texture node's ``inputs:file``."""
        inp = node.GetInput("file")
        attrs = inp.GetValueProducingAttributes(False) if inp else []
        if not attrs or _is_output(attrs[0]):
            return "", ""
        value = attrs[0].Get(self.time)
        if not isinstance(value, Sdf.AssetPath):
            return "", ""
        return value.resolvedPath or "", value.path

    def _colour_space(self, node: UsdShade.Shader, path: str, normal_map: bool) -> str:
        """The texture's ``sourceColorSpace`` (unknown tokens warned, as auto); ``auto``
        on a normal map is ``raw``: it holds vectors, not colours."""
        colour_space = str(self._node_value(node, "sourceColorSpace", "auto"))
        if colour_space not in ("sRGB", "raw", "auto"):
            self.diag.warn(f"texture {node.GetPath()} has sourceColorSpace {colour_space!r}; treated as auto", path)
            colour_space = "auto"
        if normal_map and colour_space == "auto":
            return "raw"
        if normal_map and colour_space == "sRGB":
            self.diag.warn(
                f"normal map {node.GetPath()} has sourceColorSpace 'sRGB'; decoded as sRGB as authored", path
            )
        return colour_space

    def _texture(self, node: UsdShade.Shader, output: str, path: str, slot: str, is_colour: bool) -> _TextureRef:
        resolved, authored = self._asset(node)
        normal_map = slot == NORMAL_INPUT
        colour_space = self._colour_space(node, path, normal_map)
        if normal_map and output not in ("rgb", "rgba"):
            self.diag.warn(f"normal map {node.GetPath()} is read through output {output!r}; reading rgb", path)
            output = "rgb"
        wraps = []
        for axis in ("wrapS", "wrapT"):
            token = str(self._node_value(node, axis, "useMetadata"))
            if token not in _WRAPS:
                self.diag.warn(f"texture {node.GetPath()} has {axis} {token!r}; treated as repeat", path)
            wraps.append(_WRAPS.get(token, Wrap.REPEAT))
        scale = tuple(float(v) for v in self._node_value(node, "scale", (1.0, 1.0, 1.0, 1.0)))
        bias = tuple(float(v) for v in self._node_value(node, "bias", (0.0, 0.0, 0.0, 0.0)))
        if output not in _CHANNELS:
            self.diag.warn(f"input {slot} reads output {output!r} of {node.GetPath()}; reading rgb", path)
        channel = _CHANNELS.get(output, -1)
        broadcast = -1
        if is_colour and channel >= 0:
            broadcast = channel
            scale = (scale[channel],) * 3 + (scale[3],)
            bias = (bias[channel],) * 3 + (bias[3],)
        fallback = FLAT_NORMAL_NAME if normal_map else CHECKER_NAME
        image = self.images.image(resolved, authored, colour_space, path, broadcast, fallback)
        varname, uv_transform = self._uv_source(node, path)
        binding = self.images.binding(image, wraps[0], wraps[1], scale, bias, uv_transform)
        return _TextureRef(binding, max(channel, 0), varname)

    def _uv_source(self, texture: UsdShade.Shader, path: str) -> tuple[str, tuple[float, ...]]:
        """The primvar a texture's ``st`` reads and the uv transform on the way: follow
        the connection through ``UsdTransform2d`` nodes (composed, see
        ``texture_transform``) to a ``UsdPrimvarReader_float2``."""
        node = texture
        input_name = "st"
        matrix = np.eye(3)
        for _ in range(8):
            inp = node.GetInput(input_name)
            attrs = inp.GetValueProducingAttributes(False) if inp else []
            if not attrs or not _is_output(attrs[0]):
                self.diag.warn(
                    f"texture {texture.GetPath()} has no primvar reader on st; reading {DEFAULT_UV_SET!r}", path
                )
                return DEFAULT_UV_SET, as_rows(matrix)
            node = UsdShade.Shader(attrs[0].GetPrim())
            node_id = node.GetShaderId()
            if node_id == UV_TRANSFORM_ID:
                matrix = matrix @ transform2d_matrix(node, self.time)
                input_name = "in"
                continue
            if node_id != "UsdPrimvarReader_float2":
                self.diag.warn(f"texture st is fed by {node.GetPath()} ({node_id!r}); reading {DEFAULT_UV_SET!r}", path)
                return DEFAULT_UV_SET, as_rows(matrix)
            return str(self._node_value(node, "varname", DEFAULT_UV_SET)) or DEFAULT_UV_SET, as_rows(matrix)
        self.diag.warn(
            f"texture {texture.GetPath()} st goes through more than 7 nodes; reading {DEFAULT_UV_SET!r}", path
        )
        return DEFAULT_UV_SET, as_rows(matrix)
