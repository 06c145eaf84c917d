"""Returning to a front-entry dock (seed ir-docking-flowcharts.md), for any robot with dock IR.

The seed's four phases (search, approach, align, dock) with section 2's position cases,
section 4's retries and fallback, and section 5's station sequence (charging, emptying,
standby, undock). ``tables`` holds the states; one module per phase drives them.
"""
