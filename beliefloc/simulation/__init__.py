"""Simulated worlds and episodes: act, perceive, update, replan (Colledanchise Algorithm 1, Main)."""
