"""The survey mode: the robot makes its site's map (``robotd map``; issue 30)."""

from __future__ import annotations

from behaviours.profile import ProfileSpec
from behaviours.profiles.survey.profile import SURVEY, SurveyProfile

SPEC = ProfileSpec(
    SurveyProfile,
    "makes the site's map from its LiDAR and wheel odometry while a technician drives it "
    "(robotctl drive) or while it explores to the nearest frontier; robotctl map save NAME",
    sections=(SURVEY,),
)
