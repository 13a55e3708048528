"""Does the grasp hold?  Quality measures of a grasp's contacts.

* :func:`grasp_quality` -- force closure, Ferrari-Canny epsilon (Q1) and volume of a
  solution, with the friction model of :class:`QualityOptions`;
* :func:`contact_quality`, :func:`primitive_wrenches`, :func:`force_closure`,
  :func:`hull_measures` -- the batch cores underneath;
* :func:`object_solid`, :func:`object_reference` -- the object as a solid (the one place
  that reads its shape), its centre and radius.

See ``docs/quality.md``.
"""

from .grasp import GraspQuality, configuration_quality, contact_quality, contacts_quality, grasp_quality, torque_reference
from .measures import CLOSURE_TOLERANCE, ClosureTest, force_closure, hull_facets, hull_measures
from .options import DEFAULT_FRICTION, QualityOptions
from .solid import MassProperties, Solid, mass_properties, object_reference, object_solid
from .stored import check_quality_entry, quality_entries, quality_entry
from .wrenches import cone_edges, primitive_wrenches

__all__ = [
    "QualityOptions", "GraspQuality", "grasp_quality", "contacts_quality", "configuration_quality", "contact_quality", "torque_reference",
    "quality_entry", "quality_entries", "check_quality_entry",
    "primitive_wrenches", "cone_edges", "force_closure", "ClosureTest", "hull_measures", "hull_facets", "CLOSURE_TOLERANCE",
    "Solid", "MassProperties", "object_solid", "mass_properties", "object_reference", "DEFAULT_FRICTION",
]  # fmt: skip
