"""Simulated people and servers around a robot (customers, staff, fleet), per profile."""
