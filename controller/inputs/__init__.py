"""Command inputs: scripted timelines, the terminal keyboard, a Linux gamepad."""
