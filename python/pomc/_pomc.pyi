"""Type stubs of the compiled module (use the `pomc` package's API)."""

from typing import Any, Dict, List, Optional, Tuple

import numpy as np

class PomcError(Exception):
    code: str

class Panorama:
    def __len__(self) -> int: ...
    @property
    def path(self) -> Optional[str]: ...
    @property
    def freedom_radius(self) -> float: ...
    def manifest_xml(self) -> str: ...
    def layer_info(self, k: int) -> Tuple[str, Optional[str], int]: ...
    def layer_arrays(self, k: int) -> Tuple[np.ndarray, np.ndarray, np.ndarray]: ...
    @staticmethod
    def save_into(panorama: "Panorama", dir: str) -> None: ...
    def validate_json(self) -> str: ...
    def render(
        self,
        eye: List[float],
        look_at: List[float],
        up: List[float],
        fov: float,
        size: Tuple[int, int],
        method: str,
    ) -> Tuple[np.ndarray, np.ndarray, np.ndarray, float]: ...
    def mesh(
        self,
        layer: Optional[int] = None,
        max_error: Optional[float] = None,
        max_angle: Optional[float] = None,
        simplify: bool = True,
        sky_radius: Optional[float] = None,
    ) -> List[Dict[str, Any]]: ...
    def export_mesh(
        self,
        path: str,
        max_error: Optional[float] = None,
        max_angle: Optional[float] = None,
        simplify: bool = True,
        sky_radius: Optional[float] = None,
        local: bool = False,
    ) -> List[str]: ...

def open(path: str) -> Panorama: ...
def build(colour: np.ndarray, depth: np.ndarray, options: Dict[str, Any]) -> Panorama: ...
def build_files(colour: str, depth: str, output: str, options: Dict[str, Any]) -> str: ...
