"""Formation flight (seed ch. 9 secs. 3.4-3.7): the leader-follower graph and its
checks (``spec``), sphere intersection (``geometry``), the per-vehicle guidance law
(``guidance``), the point-vehicle model (``point``), the vehicle-to-vehicle MAVLink
link (``peers``) and the quadrotor that flies the formation (``quad``)."""
from .geometry import intersection_near, nearest_on_circle, nearest_on_sphere, sphere_intersection
from .guidance import FormationGuidance, GuidanceOutput, VirtualTarget, sigma
from .spec import FormationError, FormationSpec, load_formation, parse_formation

__all__ = ["FormationError", "FormationSpec", "FormationGuidance", "GuidanceOutput",
           "VirtualTarget", "intersection_near", "load_formation", "nearest_on_circle",
           "nearest_on_sphere", "parse_formation", "sigma", "sphere_intersection"]
